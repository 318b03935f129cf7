//! `vsaqem reconstruct`: point cloud to mesh (PLY, OBJ or OFF by extension).

use crate::args::{CleanArgs, ClusterArgs, InputArgs, MemoryArgs};
use crate::clean::{read_and_clean, Cleaned, RunBytes};
use crate::input::Prepared;
use crate::io::{publish, write_atomic, write_mesh, MeshFormat};
use crate::json;
use crate::progress::StageClock;
use crate::report::{error_json, tolerance_unmet, InputReport, RunReport};
use clap::Args;
use std::path::{Path, PathBuf};
use vsaqem_core::{ClusterStats, Error, MeshingStats, Params, Reconstruction};

/// Meshing parameters; defaults are `vsaqem_core::Params::default()`.
#[derive(Args, Debug, Clone)]
pub struct MeshArgs {
    /// Support distance of the facet fitting term, fraction of the diagonal.
    #[arg(long, default_value_t = Params::default().epsilon)]
    pub epsilon: f32,
    /// Alpha of the coverage term, in multiples of the average point spacing.
    #[arg(long, default_value_t = Params::default().alpha_scale)]
    pub alpha_scale: f32,
    /// Weight of the fitting term in the facet score.
    #[arg(long, default_value_t = Params::default().fitting_weight)]
    pub fitting: f32,
    /// Weight of the coverage term in the facet score.
    #[arg(long, default_value_t = Params::default().coverage_weight)]
    pub coverage: f32,
    /// Cost of leaving a selected facet's edge without a partner (a hole edge),
    /// in units of facet score (about 0.5 per facet).
    #[arg(long, default_value_t = Params::default().border_penalty)]
    pub border_penalty: f32,
    /// Close boundary loops of the selection with at most this many edges (0: none).
    #[arg(long, default_value_t = Params::default().max_hole)]
    pub max_hole: u32,
    /// Border of the data, in degrees: a cluster whose neighbours leave a wider
    /// angular gap around it is where the data ends; boundary loops along such
    /// clusters stay open. 360 treats every input as closed.
    #[arg(long, default_value_t = Params::default().border_angle)]
    pub border_angle: f32,
    /// Branch-and-bound node limit of the facet selection.
    #[arg(long, default_value_t = Params::default().node_limit)]
    pub node_limit: u64,
    /// Rounds of fitting the mesh's vertices to the data by regularised least
    /// squares (boundary vertices stay, no face turns over; 0: off).
    #[arg(long, value_name = "N", default_value_t = Params::default().fit_rounds)]
    pub fit_rounds: u32,
    /// Vertices added where the mesh is farthest from the data, at most this
    /// fraction of its vertices: each at the farthest point of a cluster beyond
    /// the 99th percentile of the points' distances, farthest first (0: off).
    #[arg(long, value_name = "F", default_value_t = Params::default().densify)]
    pub densify: f32,
    /// Refinement rounds where parts of the data are left out of the mesh or
    /// farther than --refine-beyond from it.
    #[arg(long, default_value_t = Params::default().refine_rounds)]
    pub refine_rounds: u32,
    /// Without --max-error, refinement rounds also run while some point is
    /// farther than this from the mesh, fraction of the diagonal: a vertex is
    /// added there and the mesh made again, at most --refine-rounds times
    /// (a goal, not a bound; 0: rounds only where clusters are left out).
    #[arg(long, value_name = "F", default_value_t = Params::default().refine_beyond)]
    pub refine_beyond: f32,
    /// Error bound, fraction of the bounding-box diagonal (e.g. 0.005 = 0.5 %):
    /// where a point is farther than this from the mesh, a vertex is added
    /// there and the mesh made again, until every point is within it or the
    /// cluster cap (--max-clusters) is reached; the report says which (0: off).
    #[arg(long, value_name = "F", default_value_t = Params::default().max_error)]
    pub max_error: f32,
    /// Working memory of a meshing round, in bytes per cluster of the cap
    /// (0: 400 times the square root of --knn, 1385 at k = 12). A candidate graph
    /// denser than that fails; raise it for clouds with few points per cluster.
    #[arg(long, default_value_t = Params::default().mesh_bytes_per_cluster)]
    pub mesh_bytes_per_cluster: u32,
}

/// `vsaqem reconstruct`.
#[derive(Args, Debug)]
pub struct Cmd {
    #[command(flatten)]
    pub input: InputArgs,
    #[command(flatten)]
    pub clean: CleanArgs,
    #[command(flatten)]
    pub cluster: ClusterArgs,
    #[command(flatten)]
    pub mesh: MeshArgs,
    #[command(flatten)]
    pub memory: MemoryArgs,
    /// Output mesh: .ply, .obj or .off.
    #[arg(short, long, default_value = "mesh.ply")]
    pub output: PathBuf,
    /// Also write the report as JSON to this file.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// No progress bar.
    #[arg(short, long)]
    pub quiet: bool,
}

impl Cmd {
    /// All core parameters.
    pub fn params(&self) -> Params {
        Params {
            epsilon: self.mesh.epsilon,
            alpha_scale: self.mesh.alpha_scale,
            fitting_weight: self.mesh.fitting,
            coverage_weight: self.mesh.coverage,
            node_limit: self.mesh.node_limit,
            border_penalty: self.mesh.border_penalty,
            max_hole: self.mesh.max_hole,
            border_angle: self.mesh.border_angle,
            refine_rounds: self.mesh.refine_rounds,
            refine_beyond: self.mesh.refine_beyond,
            fit_rounds: self.mesh.fit_rounds,
            densify: self.mesh.densify,
            max_error: self.mesh.max_error,
            mesh_bytes_per_cluster: self.mesh.mesh_bytes_per_cluster,
            ..self.clean.apply(self.cluster.params())
        }
    }
}

/// Run the command.
pub fn run(cmd: &Cmd) -> Result<(), String> {
    let format =
        MeshFormat::from_path(&cmd.output).map_err(|e| format!("{}: {e}", cmd.output.display()))?;
    let mut clock = StageClock::new(!cmd.quiet).with_threads(cmd.memory.threads());
    let params = cmd.params();
    let bytes = RunBytes {
        most: vsaqem_core::arena_bytes,
        least: vsaqem_core::reconstruct_bytes_for,
    };
    let Cleaned {
        mut input,
        points_read,
        stats,
        mut buf,
        rows,
    } = read_and_clean(&cmd.input, &cmd.memory, &params, bytes, &mut clock)?;
    // The mesh needs only the points in core coordinates and the frame: the
    // positions as read (24 bytes a point) and the input order go before the
    // run, so they are not resident beside the arena.
    input.original = Vec::new();
    input.order = None;
    let arena_reserved = buf.len();
    let searched = rows.is_none();
    let arena = vsaqem_core::Arena::new(&mut buf);
    let out = input.run_core(
        vsaqem_core::reconstruct_with_rows,
        rows.as_ref().map(|r| r.rows()).as_ref(),
        &arena,
        &params,
        &mut clock,
    );
    let out = out.map_err(|e| match e {
        Error::MeshCapacity { .. } => format!(
            "{}: {e} (--mesh-bytes-per-cluster, now {})",
            input.name,
            params.mesh_capacity_per_cluster()
        ),
        Error::ArenaTooSmall { .. } | Error::ArenaTooSmallForMeshing { .. } => {
            format!("{}: {e} (--memory)", input.name)
        }
        e => format!("{}: {e}", input.name),
    })?;
    clock.time("write", || write_output(&cmd.output, format, &input, &out))?;
    let diag = out.clustered.bounds.diag;
    let report = ReconstructReport {
        input: InputReport::new(&input, points_read, stats.as_ref(), &params, diag),
        cluster: out.clustered.stats.cluster,
        tolerance: params.tolerance,
        max_error: params.max_error,
        cap: params.cluster_cap().min(input.points.len() as u32),
        split_rounds: params.split_rounds,
        meshing: out.meshing,
        run: RunReport::new(
            &clock,
            out.meshing.peak,
            arena_reserved,
            bytes.needed(
                &input,
                points_read,
                &params,
                out.clustered.stats.reverse_edges as usize,
                searched,
            ),
            &cmd.output,
        ),
    };
    if let Some((why, true)) = tolerance_unmet(&report.cluster, report.cap, report.split_rounds) {
        eprintln!(
            "warning: {}: {why}; largest error {:.3}% of the diagonal",
            input.name,
            report.cluster.max_error * 100.0
        );
    }
    if let Some(over) = report.max_error_missed() {
        eprintln!(
            "warning: {}: --max-error {} not met: the farthest point is {:.3}% of the \
             diagonal from the mesh ({:.3}% over) after {} refinement rounds with {} \
             clusters: {}",
            input.name,
            params.max_error,
            out.meshing.mesh.distance.max * 100.0,
            over * 100.0,
            out.meshing.refine_rounds,
            out.clustered.stats.cluster.clusters,
            report.max_error_stop(),
        );
    }
    publish(&report.text(), cmd.report.as_deref(), || report.json()).map_err(|e| e.to_string())
}

fn write_output(
    path: &Path,
    format: MeshFormat,
    input: &Prepared,
    out: &Reconstruction,
) -> Result<(), String> {
    let vertices: Vec<[f64; 3]> = out
        .mesh
        .vertices
        .iter()
        .map(|&v| input.frame.to_file(v))
        .collect();
    write_atomic(path, |w| {
        write_mesh(w, format, &vertices, out.mesh.triangles)
    })
    .map_err(|e| e.to_string())
}

/// The report of a run, filled once from its results: the text and the JSON read
/// only this.
struct ReconstructReport {
    input: InputReport,
    cluster: ClusterStats,
    /// `--tolerance`, as given (`cluster.tolerance` is the one used).
    tolerance: f32,
    /// `--max-error` (0: no bound).
    max_error: f32,
    /// The cluster cap.
    cap: u32,
    /// `--split-rounds`.
    split_rounds: u32,
    meshing: MeshingStats,
    run: RunReport,
}

impl ReconstructReport {
    /// By how much the farthest point exceeds `--max-error` (relative), when
    /// a bound was asked for and not met.
    fn max_error_missed(&self) -> Option<f32> {
        let max = self.meshing.mesh.distance.max;
        (self.max_error > 0.0 && max > self.max_error).then_some(max - self.max_error)
    }

    /// Why refinement stopped short of `--max-error`.
    fn max_error_stop(&self) -> &'static str {
        if self.cluster.clusters >= self.cap {
            "the cluster cap is reached (raise --max-clusters)"
        } else if self.meshing.refine_rounds >= vsaqem_core::MAX_ERROR_ROUNDS {
            "the most rounds an error bound runs"
        } else {
            "no vertex could be added where the mesh is too far"
        }
    }

    fn fit_text(&self) -> String {
        let mesh = &self.meshing.mesh;
        let densify = format!(
            "densify    {} vertices added where the mesh was farthest from the data\n",
            mesh.densified
        );
        let fit = &mesh.fit;
        if fit.rounds == 0 {
            return densify + "fit        none (--fit-rounds 0, or no faces)\n";
        }
        densify
            + &format!(
                "fit        {} vertices moved onto the data in {} rounds, {} moves taken back \
                 (a face would turn over or collapse)\n",
                fit.moved, fit.rounds, fit.reverted
            )
    }

    fn distance_text(&self) -> String {
        let d = &self.meshing.mesh.distance;
        let bound = match self.max_error_missed() {
            _ if self.max_error <= 0.0 => String::new(),
            None => format!("; bound {:.3}% met", self.max_error * 100.0),
            Some(over) => format!(
                "; bound {:.3}% NOT met ({:.3}% over: {})",
                self.max_error * 100.0,
                over * 100.0,
                self.max_error_stop()
            ),
        };
        format!(
            "distance   points to mesh: max {:.3}%, p99 {:.3}%, mean {:.4}% of the diagonal{bound}\n",
            d.max * 100.0,
            d.p99 * 100.0,
            d.mean * 100.0
        )
    }

    fn text(&self) -> String {
        let cl = &self.cluster;
        let m = &self.meshing;
        let sel = &m.selection;
        let mesh = &m.mesh;
        let solver = if sel.optimal {
            format!("optimal ({} nodes)", sel.nodes)
        } else {
            format!(
                "node limit reached, gap {:.3}% ({} nodes)",
                sel.gap * 100.0,
                sel.nodes
            )
        };
        let closed = if mesh.boundary_edges == 0 && mesh.uncovered_clusters == 0 {
            "watertight".to_string()
        } else if mesh.boundary_edges == 0 {
            format!(
                "closed, but {} clusters ({} points) are not covered",
                mesh.uncovered_clusters, mesh.uncovered_points
            )
        } else {
            format!(
                "{} boundary edges, {} uncovered clusters ({} points)",
                mesh.boundary_edges, mesh.uncovered_clusters, mesh.uncovered_points
            )
        };
        format!(
            "{}\
             clusters   {} ({} initial, +{} by splitting, +{} by refinement in {} rounds{}), max error {:.3}% of the diagonal{}\n\
             candidates {} edges, {} facets ({} degenerate, {} fold groups, {} generators merged), {:.1} supports per facet\n\
             selection  {solver}, {} independent parts (largest {} facets), {} facets fixed by propagation\n\
             mesh       {} vertices, {} faces, {} components, {closed}; {} skipped clusters inserted\n\
             {}\
             {}\
             border     {} clusters on the border of the data, {} boundary loops kept open along it\n\
             repair     {} holes closed with {} faces, {} left open; {} orientation clashes cut out; {} pinches re-meshed, {} thin parts joined, {} bubbles removed, {} vertices split; {} crossing or folded face pairs left\n\
             {}",
            self.input.text(),
            cl.clusters,
            cl.initial_clusters,
            cl.splits,
            m.refine_added,
            m.refine_rounds + m.gap_rounds,
            if m.gap_rounds > 0 {
                format!(", {} of them for gaps in the data", m.gap_rounds)
            } else {
                String::new()
            },
            cl.max_error * 100.0,
            tolerance_unmet(cl, self.cap, self.split_rounds).map_or(String::new(), |(why, _)| format!("; {why}")),
            m.candidate_edges,
            m.candidate_facets,
            m.degenerate_facets,
            m.fold_groups,
            m.merged_generators,
            m.mean_supports,
            sel.components,
            sel.largest_component,
            sel.forced,
            mesh.vertices,
            mesh.faces,
            mesh.components,
            mesh.inserted_clusters,
            self.fit_text(),
            self.distance_text(),
            m.border_clusters,
            mesh.open_loops,
            mesh.holes_filled,
            mesh.filled_faces,
            mesh.holes_left,
            mesh.repairs,
            mesh.pinches_repaired,
            mesh.necks,
            mesh.bubbles_removed,
            mesh.split_vertices,
            mesh.tangled_pairs,
            self.run.text(self.input.points, ""),
        )
    }

    fn json(&self) -> String {
        let cl = &self.cluster;
        let m = &self.meshing;
        let sel = &m.selection;
        let mesh = &m.mesh;
        let mut o = json::Obj::default();
        self.input.json(&mut o);
        o.num("clusters", cl.clusters as f64)
            .num("initial_clusters", cl.initial_clusters as f64)
            .num("splits", cl.splits as f64)
            .num("refine_rounds", m.refine_rounds as f64)
            .num("gap_rounds", m.gap_rounds as f64)
            .num("refine_added", m.refine_added as f64)
            .num("passes", cl.passes as f64);
        error_json(&mut o, cl, self.tolerance, self.cap);
        o.num("candidate_edges", m.candidate_edges as f64)
            .num("candidate_facets", m.candidate_facets as f64)
            .num("degenerate_facets", m.degenerate_facets as f64)
            .num("fold_groups", m.fold_groups as f64)
            .num("merged_generators", m.merged_generators as f64)
            .bool("solver_optimal", sel.optimal)
            .num("solver_gap", sel.gap)
            .num("solver_nodes", sel.nodes as f64)
            .num("solver_objective", sel.objective)
            .num("solver_upper_bound", sel.upper_bound)
            .num("solver_components", sel.components as f64)
            .num("solver_largest_component", sel.largest_component as f64)
            .num("vertices", mesh.vertices as f64)
            .num("faces", mesh.faces as f64)
            .num("boundary_edges", mesh.boundary_edges as f64)
            .num("components", mesh.components as f64)
            .num("non_orientable_components", mesh.non_orientable as f64)
            .num("pinches_repaired", mesh.pinches_repaired as f64)
            .num("thin_parts_joined", mesh.necks as f64)
            .num("bubbles_removed", mesh.bubbles_removed as f64)
            .num("tangled_pairs", mesh.tangled_pairs as f64)
            .num("split_vertices", mesh.split_vertices as f64)
            .num("border_clusters", m.border_clusters as f64)
            .num("open_loops", mesh.open_loops as f64)
            .num("holes_filled", mesh.holes_filled as f64)
            .num("filled_faces", mesh.filled_faces as f64)
            .num("holes_left", mesh.holes_left as f64)
            .num("orientation_repairs", mesh.repairs as f64)
            .num("inserted_clusters", mesh.inserted_clusters as f64)
            .num("densified", mesh.densified as f64)
            .num("uncovered_clusters", mesh.uncovered_clusters as f64)
            .num("uncovered_points", mesh.uncovered_points as f64)
            .num("fit_rounds", mesh.fit.rounds as f64)
            .num("fitted_vertices", mesh.fit.moved as f64)
            .num("fit_reverted", mesh.fit.reverted as f64)
            .num("distance_max_relative", mesh.distance.max as f64)
            .num("distance_p99_relative", mesh.distance.p99 as f64)
            .num("distance_mean_relative", mesh.distance.mean as f64)
            // `max_error_relative` is clustering's (as in `cluster`'s report).
            .num("error_bound_relative", self.max_error as f64);
        if self.max_error > 0.0 {
            o.bool("error_bound_met", self.max_error_missed().is_none());
        }
        self.run.json(&mut o);
        o.finish() + "\n"
    }
}
