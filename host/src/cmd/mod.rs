//! The subcommands.

pub mod cluster;
pub mod eval;
pub mod reconstruct;
pub mod render;

use crate::input::Prepared;
use crate::progress::StageClock;
use clap::Args;
use std::mem::MaybeUninit;
use vsaqem_core::{Arena, CleanStats, Error, Params};

/// The arena budget of a run.
#[derive(Args, Debug, Clone)]
pub struct MemoryArgs {
    /// Arena size in bytes (suffixes KiB, MiB, GiB; e.g. 64MiB, 1.5GiB, 200000).
    /// Default: the most this run can need, as core bounds it for these points
    /// and parameters. Less than that fails at once, naming the size needed;
    /// more is allowed but never used.
    #[arg(long, value_name = "BYTES", value_parser = parse_bytes)]
    pub memory: Option<usize>,
}

impl MemoryArgs {
    /// The arena size to use when the run needs `needed` bytes at most: the
    /// `--memory` budget, checked against `needed` before any work, or `needed`.
    pub fn arena_size(&self, needed: usize, points: usize) -> Result<usize, String> {
        match self.memory {
            None => Ok(needed),
            Some(given) if given >= needed => Ok(given),
            Some(given) => Err(format!(
                "--memory {given} bytes ({:.1} MiB) is too small: this run needs {needed} \
                 bytes ({:.1} MiB) for {points} points with these parameters; give at \
                 least that, or use fewer clusters or neighbours",
                mib(given),
                mib(needed)
            )),
        }
    }
}

fn mib(bytes: usize) -> f64 {
    bytes as f64 / (1u64 << 20) as f64
}

/// A byte count: a whole number of bytes, or a number with a unit: `KiB`, `MiB`,
/// `GiB` (also `K`, `M`, `G`), `KB`, `MB`, `GB` (powers of 1000) or `B`, any
/// case, e.g. `64MiB`, `1.5GiB`, `200000`. Fractions of a byte are dropped.
pub fn parse_bytes(s: &str) -> Result<usize, String> {
    let t = s.trim();
    let at = t.find(|c: char| c.is_ascii_alphabetic()).unwrap_or(t.len());
    let (number, unit) = (t[..at].trim(), t[at..].trim());
    let scale: u64 = match unit.to_ascii_lowercase().as_str() {
        "" | "b" => 1,
        "k" | "kib" => 1 << 10,
        "m" | "mib" => 1 << 20,
        "g" | "gib" => 1 << 30,
        "kb" => 1_000,
        "mb" => 1_000_000,
        "gb" => 1_000_000_000,
        _ => {
            return Err(format!(
                "'{s}': unknown unit '{unit}' (use bytes, KiB, MiB or GiB, e.g. 64MiB)"
            ))
        }
    };
    let too_large = || format!("'{s}': too large for this machine");
    if !number.is_empty() && number.bytes().all(|b| b.is_ascii_digit()) {
        let whole: u64 = number.parse().map_err(|_| too_large())?;
        let bytes = whole.checked_mul(scale).ok_or_else(too_large)?;
        return usize::try_from(bytes).map_err(|_| too_large());
    }
    let value: f64 = number
        .parse()
        .ok()
        .filter(|v: &f64| v.is_finite() && *v >= 0.0 && !number.starts_with(['+', '-']))
        .ok_or_else(|| format!("'{s}': not a size (a number of bytes, or e.g. 64MiB)"))?;
    if scale == 1 && value.fract() != 0.0 {
        return Err(format!("'{s}': not a whole number of bytes"));
    }
    let bytes = (value * scale as f64).floor();
    if bytes >= usize::MAX as f64 || bytes >= (1u64 << 53) as f64 {
        return Err(too_large());
    }
    Ok(bytes as usize)
}

/// A buffer of `bytes` uninitialised bytes for the core arena. The pages are not
/// touched until core uses them, so the process's resident memory follows the
/// arena's real use, not its size.
pub fn arena_buffer(bytes: usize) -> Vec<MaybeUninit<u8>> {
    let mut v = Vec::with_capacity(bytes);
    v.resize(bytes, MaybeUninit::uninit());
    v
}

/// The arena a run on `n` points needs when `run` bytes are enough for the
/// command itself: also enough for the cleaning pre-pass when it is on (it runs
/// first, in the same buffer).
pub fn with_clean(run: usize, n: usize, params: &Params) -> usize {
    let run = run.max(vsaqem_core::smooth_bytes(n, params));
    if params.cleans() {
        run.max(vsaqem_core::clean_bytes(n, params))
    } else {
        run
    }
}

/// The cleaning pre-pass (`vsaqem_core::clean`), then the kept points compacted
/// and normalised again, then `--smooth` rounds of smoothing. `None` when both
/// filters are off; the input is handed back untouched when nothing is removed
/// and nothing smoothed, so the output is then the same as without cleaning.
///
/// Each pre-pass gets a buffer of its own, at most `buf`'s size (the budget),
/// freed when it ends: working in `buf` would leave its pages resident beside
/// those the reconstruction then touches (1M points: 175 MB peak RSS instead of
/// 139 MB), while `buf`'s own pages stay untouched until the run uses them.
pub fn clean_input(
    input: Prepared,
    params: &Params,
    buf: &mut [MaybeUninit<u8>],
    clock: &mut StageClock,
) -> Result<(Prepared, Option<CleanStats>), String> {
    let budget = buf.len();
    let (mut input, stats) = filter_input(input, params, budget, clock)?;
    if params.smooth_rounds > 0 {
        let need = vsaqem_core::smooth_bytes(input.points.len(), params);
        let mut own = arena_buffer(need.min(budget));
        let arena = Arena::new(&mut own);
        vsaqem_core::smooth(&arena, &mut input.points, params, clock)
            .map_err(|e| format!("{}: smoothing: {e}", input.name))?;
    }
    Ok((input, stats))
}

/// The cleaning filters of [`clean_input`].
fn filter_input(
    input: Prepared,
    params: &Params,
    budget: usize,
    clock: &mut StageClock,
) -> Result<(Prepared, Option<CleanStats>), String> {
    if !params.cleans() {
        return Ok((input, None));
    }
    let need = vsaqem_core::clean_bytes(input.points.len(), params);
    let mut own = arena_buffer(need.min(budget));
    let arena = Arena::new(&mut own);
    let mut keep = vec![true; input.points.len()];
    let stats = match vsaqem_core::clean(&arena, &input.points, params, &mut keep, clock) {
        Ok(s) => s,
        Err(e @ Error::TooFewKept { .. }) => {
            return Err(format!(
                "{}: {e} (--outliers {}, --min-fragment {})",
                input.name, params.outlier_sigma, params.min_fragment
            ))
        }
        Err(e) => return Err(format!("{}: {e}", input.name)),
    };
    if stats.kept == stats.points {
        return Ok((input, Some(stats)));
    }
    Ok((input.keep(&keep), Some(stats)))
}

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

#[cfg(test)]
mod tests {
    use super::parse_bytes;

    #[test]
    fn sizes_parse_with_and_without_units() {
        assert_eq!(parse_bytes("200000"), Ok(200_000));
        assert_eq!(parse_bytes("64MiB"), Ok(64 << 20));
        assert_eq!(parse_bytes("1.5GiB"), Ok(3 << 29));
        assert_eq!(parse_bytes("512 KiB"), Ok(512 << 10));
        assert_eq!(parse_bytes("2k"), Ok(2048));
        assert_eq!(parse_bytes("3MB"), Ok(3_000_000));
        assert_eq!(parse_bytes("100b"), Ok(100));
        assert_eq!(parse_bytes("0.5KiB"), Ok(512));
        assert_eq!(parse_bytes("1.0001KiB"), Ok(1024));
        for bad in [
            "",
            "MiB",
            "-5",
            "+5",
            "1.5",
            "12 parsecs",
            "1e400GiB",
            "nan",
            "0x10",
        ] {
            let e = parse_bytes(bad).unwrap_err();
            assert!(e.contains(&format!("'{bad}'")), "{bad}: {e}");
        }
        assert!(parse_bytes("99999999999999999999999").is_err());
        assert!(parse_bytes("99999999999GiB").is_err());
    }
}
