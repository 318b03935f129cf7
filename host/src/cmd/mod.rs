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

/// A bright, deterministic colour for cluster `label`.
pub fn label_colour(label: u32) -> [u8; 3] {
    let mut z = (label as u64).wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    let h = (z >> 11) as f64 / (1u64 << 53) as f64 * 6.0;
    let (s, v) = (0.65, 0.95);
    let c = v * s;
    let x = c * (1.0 - ((h % 2.0) - 1.0).abs());
    let (r, g, b) = match h as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = v - c;
    [r, g, b].map(|t| ((t + m) * 255.0).round() as u8)
}

/// Print the text report and, when asked, write the JSON report atomically.
pub fn publish(
    text: &str,
    json_path: Option<&std::path::Path>,
    json: impl FnOnce() -> String,
) -> Result<(), String> {
    print!("{text}");
    if let Some(path) = json_path {
        let body = json();
        crate::io::write_atomic(path, |w| w.write_all(body.as_bytes()))
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}
