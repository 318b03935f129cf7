//! The subcommands.

pub mod cluster;
pub mod eval;
pub mod reconstruct;
pub mod render;

use vsaqem_core::{CleanStats, Params};

/// The report's `clean` line (without the label).
pub fn clean_text(stats: Option<&CleanStats>, params: &Params) -> String {
    let Some(s) = stats else {
        return "off".to_string();
    };
    let outliers = if params.outlier_sigma > 0.0 {
        format!(
            "{} removed (over {} standard deviations)",
            count(s.outliers, "outlier"),
            params.outlier_sigma
        )
    } else {
        "outlier filter off".to_string()
    };
    let fragments = if params.min_fragment > 0 {
        format!(
            "{} dropped ({}; pieces under {} points)",
            count(s.fragments, "fragment"),
            count(s.fragment_points, "point"),
            params.min_fragment
        )
    } else {
        "fragment filter off".to_string()
    };
    let pieces = if params.min_fragment > 0 {
        format!(" in {}", count(s.pieces, "piece"))
    } else {
        String::new()
    };
    format!(
        "{outliers}, {fragments}; {} of {} points kept{pieces}",
        s.kept, s.points
    )
}

/// `"1 point"`, `"3 points"`.
fn count(n: u32, what: &str) -> String {
    if n == 1 {
        format!("1 {what}")
    } else {
        format!("{n} {what}s")
    }
}

/// The report's cleaning fields (zeros when cleaning is off).
pub fn clean_json(
    o: &mut crate::json::Obj,
    stats: Option<&CleanStats>,
    read: usize,
    params: &Params,
) {
    let s = stats.copied().unwrap_or_default();
    o.num("points_read", read as f64)
        .num("outlier_sigma", params.outlier_sigma as f64)
        .num("min_fragment", params.min_fragment as f64)
        .num("outliers_removed", s.outliers as f64)
        .num("fragments_dropped", s.fragments as f64)
        .num("fragment_points", s.fragment_points as f64);
}
