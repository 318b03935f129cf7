//! Clustering benchmark over the shared clouds (../shared/data/clouds/*.ply).
//!
//! `cargo bench -p vsaqem --bench cluster [-- CLUSTERS ITERATIONS]` prints, per
//! model: points, clusters, passes, time per stage (best of 3 runs, one core),
//! arena peak and bytes per point. Skipped with a message when the data is absent.

use std::path::Path;
use std::time::Duration;
use vsaqem::args::arena_buffer;
use vsaqem::input::prepare;
use vsaqem::io::read_cloud;
use vsaqem::progress::StageClock;
use vsaqem_core::{cluster, cluster_bytes, Arena, Params};

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    let clusters = args.first().and_then(|s| s.parse().ok()).unwrap_or(1000);
    let iterations = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(5);
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/clouds");
    let Ok(entries) = std::fs::read_dir(&dir) else {
        println!(
            "skipped: {} not found (the shared data sits beside the repository)",
            dir.display()
        );
        return;
    };
    let mut files: Vec<_> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "ply"))
        .collect();
    files.sort();
    let params = Params {
        clusters,
        iterations,
        ..Params::default()
    };
    println!("clustering at {clusters} clusters, {iterations} iterations (defaults otherwise); times: best of 3 runs\n");
    println!(
        "| model | points | clusters | passes | neighbours ms | quadrics ms | clustering ms | total ms | max error % | arena peak B | B/point |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for path in files {
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        let cloud = match read_cloud(&path) {
            Ok(c) => c,
            Err(e) => {
                println!("| {name} | read failed: {e} |");
                continue;
            }
        };
        let input = prepare(name.clone(), cloud);
        let n = input.points.len();
        let mut best: Option<(Duration, Vec<(&'static str, Duration)>)> = None;
        let mut stats = None;
        for _ in 0..3 {
            let mut buf = arena_buffer(cluster_bytes(n, &params));
            let arena = Arena::new(&mut buf);
            let mut clock = StageClock::new(false);
            let out = cluster(
                &arena,
                &input.points,
                input.normals.as_deref(),
                &params,
                &mut clock,
            );
            clock.finish();
            let out = match out {
                Ok(o) => o,
                Err(e) => {
                    println!("| {name} | failed: {e} |");
                    break;
                }
            };
            let total: Duration = clock.times.iter().map(|(_, d)| *d).sum();
            if best.as_ref().is_none_or(|(t, _)| total < *t) {
                best = Some((total, clock.times.clone()));
            }
            stats = Some(out.stats);
        }
        let (Some((total, times)), Some(s)) = (best, stats) else {
            continue;
        };
        let get = |k: &str| {
            times
                .iter()
                .filter(|(n, _)| *n == k)
                .map(|(_, d)| d.as_secs_f64() * 1e3)
                .sum::<f64>()
        };
        println!(
            "| {name} | {n} | {} | {} | {:.1} | {:.1} | {:.1} | {:.1} | {:.3} | {} | {:.1} |",
            s.cluster.clusters,
            s.cluster.passes,
            get("neighbours"),
            get("quadrics"),
            get("clustering"),
            total.as_secs_f64() * 1e3,
            s.cluster.max_error * 100.0,
            s.peak_clustering,
            s.peak_clustering as f64 / n as f64
        );
    }
}
