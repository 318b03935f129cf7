//! The largest counts and sizes the host takes from its arguments and files,
//! each checked before anything is allocated for it: a value past its limit is
//! an error naming the option, the value and the limit, never an allocation
//! the system refuses (which aborts the process) or a capacity overflow (which
//! panics). README.md ("Limits") lists the same numbers.

use std::fmt;

/// Most points of a built-in sample (`--points`).
pub const MAX_SAMPLE_POINTS: usize = 100_000_000;

/// Most bytes a meshing round may reserve per cluster of the cap
/// (`--mesh-bytes-per-cluster`): about 750 times the default at k = 12.
pub const MAX_MESH_BYTES_PER_CLUSTER: u32 = 1 << 20;

/// Most surface samples of `eval` (`--samples`): 100 times the default.
pub const MAX_EVAL_SAMPLES: usize = 10_000_000;

/// Most bytes read from one input file or standard input: 4 GiB (some 130
/// million points of text, whose arena alone would be near 20 GB).
pub const MAX_INPUT_BYTES: u64 = 4 << 30;

/// Most arena bytes where the machine's physical memory is not known.
const FALLBACK_MEMORY: u64 = 1 << 40;

/// `Err` naming `option`, `value` and `limit` when `value > limit`.
pub fn at_most(option: &str, value: u64, limit: u64, what: &str) -> Result<(), String> {
    if value <= limit {
        return Ok(());
    }
    Err(format!(
        "{option} {value} is more than the limit of {limit} {what}"
    ))
}

/// The most memory a run may reserve: the machine's physical memory where the
/// system says it (Linux: `MemTotal` of `/proc/meminfo`), else 1 TiB; never more
/// than an allocation can be (`isize::MAX` bytes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryLimit {
    /// The limit in bytes.
    pub bytes: usize,
    /// Whether it is the machine's physical memory (else the fixed cap).
    pub physical: bool,
}

impl MemoryLimit {
    /// This machine's limit.
    pub fn of_machine() -> MemoryLimit {
        let physical = std::fs::read_to_string("/proc/meminfo")
            .ok()
            .and_then(|s| mem_total(&s));
        let bytes = physical.unwrap_or(FALLBACK_MEMORY);
        MemoryLimit {
            bytes: usize::try_from(bytes)
                .unwrap_or(usize::MAX)
                .min(isize::MAX as usize),
            physical: physical.is_some(),
        }
    }
}

impl fmt::Display for MemoryLimit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let gib = self.bytes as f64 / (1u64 << 30) as f64;
        if self.physical {
            write!(
                f,
                "this machine's physical memory, {} bytes ({gib:.1} GiB)",
                self.bytes
            )
        } else {
            write!(
                f,
                "the limit of {} bytes ({gib:.1} GiB) where the physical memory is not known",
                self.bytes
            )
        }
    }
}

/// The `MemTotal` of a `/proc/meminfo` text, in bytes.
fn mem_total(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find(|l| l.starts_with("MemTotal:"))?;
    let mut words = line["MemTotal:".len()..].split_whitespace();
    let kib: u64 = words.next()?.parse().ok()?;
    (words.next() == Some("kB")).then_some(())?;
    kib.checked_mul(1024).filter(|&b| b > 0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mem_total_reads_kib_and_refuses_what_it_cannot_read() {
        let info = "MemTotal:       24684084 kB\nMemFree:  100 kB\n";
        assert_eq!(mem_total(info), Some(24_684_084 * 1024));
        assert_eq!(mem_total("MemFree: 5 kB\n"), None);
        assert_eq!(mem_total("MemTotal: lots kB\n"), None);
        assert_eq!(mem_total("MemTotal: 5 MB\n"), None);
        assert_eq!(mem_total("MemTotal: 0 kB\n"), None);
    }

    #[test]
    fn a_value_past_its_limit_names_option_value_and_limit() {
        assert!(at_most("--points", 100, 100, "points").is_ok());
        let e = at_most("--points", 101, 100, "points").unwrap_err();
        assert_eq!(e, "--points 101 is more than the limit of 100 points");
    }
}
