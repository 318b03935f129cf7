//! Helpers shared by the host's benchmarks.

use std::path::{Path, PathBuf};
use std::time::Duration;
use vsaqem::progress::StageClock;

/// The shared clouds (`../shared/data/clouds/*.ply`, beside the repository),
/// sorted; `None`, after printing `skipped: ...`, when the folder is absent.
pub fn shared_clouds() -> Option<Vec<PathBuf>> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/clouds");
    let Ok(entries) = std::fs::read_dir(&dir) else {
        println!(
            "skipped: {} not found (the shared data sits beside the repository)",
            dir.display()
        );
        return None;
    };
    let mut files: Vec<_> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "ply"))
        .collect();
    files.sort();
    Some(files)
}

/// The stage times of the fastest of repeated runs (by the sum of its stages).
#[derive(Default)]
pub struct Fastest(Option<(Duration, Vec<(&'static str, Duration)>)>);

impl Fastest {
    /// Keep the stage times of `clock` when they sum to less than the fastest's.
    pub fn offer(&mut self, clock: &StageClock) {
        let total: Duration = clock.times.iter().map(|(_, d)| *d).sum();
        if self.0.as_ref().is_none_or(|(t, _)| total < *t) {
            self.0 = Some((total, clock.times.clone()));
        }
    }

    /// The fastest run's stages in total, in milliseconds; `None` before any run.
    pub fn total_ms(&self) -> Option<f64> {
        self.0.as_ref().map(|(t, _)| t.as_secs_f64() * 1e3)
    }

    /// Milliseconds the fastest run spent in the stages `names` (0 before any run).
    pub fn ms(&self, names: &[&str]) -> f64 {
        self.0.as_ref().map_or(0.0, |(_, times)| {
            times
                .iter()
                .filter(|(n, _)| names.contains(n))
                .map(|(_, d)| d.as_secs_f64() * 1e3)
                .sum()
        })
    }
}
