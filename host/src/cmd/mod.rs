//! The subcommands.

pub mod cluster;
pub mod eval;
pub mod reconstruct;
pub mod render;

use std::mem::MaybeUninit;

/// A buffer of `bytes` uninitialised bytes for the core arena. The pages are not
/// touched until core uses them, so the process's resident memory follows the
/// arena's real use, not its size.
pub fn arena_buffer(bytes: usize) -> Vec<MaybeUninit<u8>> {
    let mut v = Vec::with_capacity(bytes);
    v.resize(bytes, MaybeUninit::uninit());
    v
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
