//! Reconstruction benchmark over the shared clouds (../shared/data/clouds/*.ply).
//!
//! `cargo bench -p vsaqem --bench reconstruct [-- CLUSTERS...]` prints, per model and
//! cluster count (default 250 500 1000 2000): vertices, faces, boundary edges,
//! boundary loops kept open along the border of the data, components, holes
//! closed, the share of the points read farther than 1 % of the diagonal from the
//! mesh, solver status and gap, time per stage (of the fastest of 3 runs, one
//! core) and arena peak. Runs as the CLI does at its defaults: the cleaning
//! pre-pass, then reconstruct. Skipped with a message when the data is absent.

mod common;

use vsaqem::args::arena_buffer;
use vsaqem::clean::clean_input;
use vsaqem::input::prepare;
use vsaqem::io::read_cloud;
use vsaqem::progress::StageClock;
use vsaqem_core::{arena_bytes, reconstruct_with_rows, Arena, Params};

fn main() {
    let mut counts: Vec<u32> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    if counts.is_empty() {
        counts = vec![250, 500, 1000, 2000];
    }
    let Some(files) = common::shared_clouds() else {
        return;
    };
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
        let read = match prepare(name.clone(), cloud) {
            Ok(read) => read,
            Err(e) => {
                println!("| {name} | failed: {e} |");
                continue;
            }
        };
        let all = read.original.clone();
        let mut buf =
            arena_buffer(vsaqem_core::clean_bytes(all.len(), &Params::default())).expect("arena");
        let mut clock = StageClock::new(false);
        let input = match clean_input(read, &Params::default(), &mut buf, &mut clock) {
            Ok((input, _, _)) => input,
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
            let mut best = common::Fastest::default();
            let mut last = None;
            for _ in 0..3 {
                let mut buf =
                    arena_buffer(arena_bytes(input.points.len(), &params)).expect("arena");
                let arena = Arena::new(&mut buf);
                let mut clock = StageClock::new(false);
                let out = match input.run_core(
                    reconstruct_with_rows,
                    None,
                    &arena,
                    &params,
                    &mut clock,
                ) {
                    Ok(o) => o,
                    Err(e) => {
                        println!("| {name} | {clusters} | failed: {e} |");
                        break;
                    }
                };
                best.offer(&clock);
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
            let (Some(total), Some((m, cl, far))) = (best.total_ms(), last) else {
                continue;
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
                best.ms(&["neighbours"]),
                best.ms(&["quadrics"]),
                best.ms(&["validate", "clustering"]),
                best.ms(&["candidates"]),
                best.ms(&["scoring"]),
                best.ms(&["selection"]),
                best.ms(&["output"]),
                total,
                m.peak
            );
        }
    }
}
