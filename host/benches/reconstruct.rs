//! Reconstruction benchmark over the shared clouds (../shared/data/clouds/*.ply).
//!
//! `cargo bench -p vsaqem --bench reconstruct [-- CLUSTERS...]` prints, per model and
//! cluster count (default 250 500 1000 2000): vertices, faces, boundary edges,
//! boundary loops kept open along the border of the data, components, holes
//! closed, the share of the points read farther than 1 % of the diagonal from the
//! mesh, solver status and gap, time per stage (of the fastest of 3 runs, one
//! core) and arena peak. Runs as the CLI does at its defaults: the cleaning
//! pre-pass, then reconstruct. Skipped with a message when the data is absent.

use std::path::Path;
use std::time::Duration;
use vsaqem::args::arena_buffer;
use vsaqem::clean::clean_input;
use vsaqem::input::prepare;
use vsaqem::io::read_cloud;
use vsaqem::progress::StageClock;
use vsaqem_core::{arena_bytes, reconstruct, Arena, Params};

fn main() {
    let mut counts: Vec<u32> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    if counts.is_empty() {
        counts = vec![250, 500, 1000, 2000];
    }
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
    println!("reconstruction, 5 iterations, defaults otherwise; times: best of 3 runs, one core\n");
    println!("| model | clusters (asked → after splitting) | vertices | faces | boundary edges | open loops | components | holes closed | points > 1 % | solver | nodes | neighbours ms | quadrics ms | clustering ms | candidates ms | scoring ms | selection ms | output ms | total ms | arena peak B |");
    println!(
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    );
    for path in files {
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        let Ok(cloud) = read_cloud(&path) else {
            continue;
        };
        let read = prepare(name.clone(), cloud);
        let all = read.original.clone();
        let mut buf = arena_buffer(vsaqem_core::clean_bytes(all.len(), &Params::default()));
        let mut clock = StageClock::new(false);
        let input = match clean_input(read, &Params::default(), &mut buf, &mut clock) {
            Ok((input, _)) => input,
            Err(e) => {
                println!("| {name} | failed: {e} |");
                continue;
            }
        };
        for &clusters in &counts {
            let params = Params {
                clusters,
                ..Params::default()
            };
            let mut best: Option<(Duration, Vec<(&'static str, Duration)>)> = None;
            let mut last = None;
            for _ in 0..3 {
                let mut buf = arena_buffer(arena_bytes(input.points.len(), &params));
                let arena = Arena::new(&mut buf);
                let mut clock = StageClock::new(false);
                let out = reconstruct(
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
                        println!("| {name} | {clusters} | failed: {e} |");
                        break;
                    }
                };
                let total: Duration = clock.times.iter().map(|(_, d)| *d).sum();
                if best.as_ref().is_none_or(|(t, _)| total < *t) {
                    best = Some((total, clock.times.clone()));
                }
                // Coverage of every point read, in file coordinates.
                let v: Vec<[f64; 3]> = out
                    .mesh
                    .vertices
                    .iter()
                    .map(|&p| input.frame.to_file(p))
                    .collect();
                let far = vsaqem::eval::evaluate(&all, &v, out.mesh.triangles, 1000)
                    .point_to_mesh
                    .far;
                last = Some((out.meshing, out.clustered.stats.cluster.clusters, far));
            }
            let (Some((total, times)), Some((m, cl, far))) = (best, last) else {
                continue;
            };
            let get = |ks: &[&str]| {
                times
                    .iter()
                    .filter(|(n, _)| ks.contains(n))
                    .map(|(_, d)| d.as_secs_f64() * 1e3)
                    .sum::<f64>()
            };
            let solver = if m.selection.optimal {
                "optimal".to_string()
            } else {
                format!("gap {:.2}%", m.selection.gap * 100.0)
            };
            println!(
                "| {name} | {clusters} → {cl} | {} | {} | {} | {} | {} | {} | {:.2} % | {solver} | {} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {} |",
                m.mesh.vertices,
                m.mesh.faces,
                m.mesh.boundary_edges,
                m.mesh.open_loops,
                m.mesh.components,
                m.mesh.holes_filled,
                100.0 * far as f64 / all.len() as f64,
                m.selection.nodes,
                get(&["neighbours"]),
                get(&["quadrics"]),
                get(&["validate", "clustering"]),
                get(&["candidates"]),
                get(&["scoring"]),
                get(&["selection"]),
                get(&["output"]),
                total.as_secs_f64() * 1e3,
                m.peak
            );
        }
    }
}
