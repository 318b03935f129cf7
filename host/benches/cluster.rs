//! Clustering benchmark over the shared clouds (../shared/data/clouds/*.ply).
//!
//! `cargo bench -p vsaqem --bench cluster [-- CLUSTERS ITERATIONS]` prints, per
//! model: points, clusters, passes, time per stage (best of 3 runs, one core),
//! arena peak and bytes per point. Skipped with a message when the data is absent.

mod common;

use vsaqem::args::arena_buffer;
use vsaqem::input::prepare;
use vsaqem::io::read_cloud;
use vsaqem::progress::StageClock;
use vsaqem_core::{cluster_bytes, cluster_with_rows, Arena, Params};

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    let clusters = args.first().and_then(|s| s.parse().ok()).unwrap_or(1000);
    let iterations = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(5);
    let Some(files) = common::shared_clouds() else {
        return;
    };
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
        let input = match prepare(name.clone(), cloud) {
            Ok(input) => input,
            Err(e) => {
                println!("| {name} | failed: {e} |");
                continue;
            }
        };
        let n = input.points.len();
        let mut best = common::Fastest::default();
        let mut stats = None;
        for _ in 0..3 {
            let mut buf = arena_buffer(cluster_bytes(n, &params)).expect("arena");
            let arena = Arena::new(&mut buf);
            let mut clock = StageClock::new(false);
            let out = match input.run_core(cluster_with_rows, None, &arena, &params, &mut clock) {
                Ok(o) => o,
                Err(e) => {
                    println!("| {name} | failed: {e} |");
                    break;
                }
            };
            best.offer(&clock);
            stats = Some(out.stats);
        }
        let (Some(total), Some(s)) = (best.total_ms(), stats) else {
            continue;
        };
        println!(
            "| {name} | {n} | {} | {} | {:.1} | {:.1} | {:.1} | {:.1} | {:.3} | {} | {:.1} |",
            s.cluster.clusters,
            s.cluster.passes,
            best.ms(&["neighbours"]),
            best.ms(&["quadrics"]),
            best.ms(&["clustering"]),
            total,
            s.cluster.max_error * 100.0,
            s.peak_clustering,
            s.peak_clustering as f64 / n as f64
        );
    }
}
