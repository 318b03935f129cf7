//! `vsaqem reconstruct`: point cloud to mesh (PLY, OBJ, OFF, STL or GLB by
//! extension; `-o -`: PLY on standard output).

use crate::args::{CleanArgs, ClusterArgs, InputArgs, MemoryArgs};
use crate::attributes::{vertex_colors, vertex_normals};
use crate::clean::{read_and_clean, Cleaned, RunBytes};
use crate::io::write::mesh::AUTO_F32_SHARE;
use crate::io::{stage_to, write_mesh, MeshFormat, MeshLayout, MeshOut, Precision};
use crate::limits::{at_most, MAX_MESH_BYTES_PER_CLUSTER};
use crate::outputs::check_outputs;
use crate::progress::StageClock;
use crate::report::{
    publish, report_json, ClusteringReport, FileReport, Header, InputReport, MeshCheck,
    ParamsReport, RunParams, RunReport, StagePeaks,
};
use crate::stdout;
use clap::Args;
use serde::Serialize;
use std::path::PathBuf;
use vsaqem_core::{Error, MeshingStats, Params, Unmeshable, MIN_EPSILON, MIN_MESH_CLUSTERS};

/// Meshing parameters; defaults are `vsaqem_core::Params::default()`.
#[derive(Args, Debug, Clone)]
#[command(next_help_heading = "Meshing")]
pub struct MeshArgs {
    /// Support distance of the facet fitting term, fraction of the diagonal
    /// (at least 1.1920929e-7, the precision of the coordinates).
    #[arg(long, default_value_t = Params::default().epsilon)]
    pub epsilon: f32,
    /// Alpha of the coverage term, in multiples of the average point spacing.
    #[arg(long, default_value_t = Params::default().alpha_scale)]
    pub alpha_scale: f32,
    /// Weight of the fitting term in the facet score.
    #[arg(long, default_value_t = Params::default().fitting_weight)]
    pub fitting: f32,
    /// Weight of the coverage term in the facet score (it and --fitting not
    /// both 0).
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
    /// farther than --refine-beyond from it; where clusters are still left out
    /// after them, one more round, kept only if its mesh leaves out no more
    /// points (0: none).
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
    /// (0: 400 times the square root of --knn, 1385 at k = 12; at most 1048576).
    /// A candidate graph denser than that fails; raise it for clouds with few
    /// points per cluster.
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
    /// Output mesh: .ply (binary, with vertex normals and the input's
    /// colours), .obj (with normals), .off, .stl (binary) or .glb (glTF binary,
    /// with normals and colours); - writes PLY to standard output and the
    /// report's text to standard error. Not the input; its directory must exist
    /// and be writable, checked before any work.
    #[arg(short, long, default_value = "mesh.ply", help_heading = "Output")]
    pub output: PathBuf,
    /// Coordinates of the output: auto writes float32 unless the spacing of
    /// float32 values at the mesh's largest coordinate is over 1 % of the
    /// tolerance (--tolerance × the diagonal; e.g. clouds at UTM coordinates),
    /// then float64 (PLY double; GLB float32 offsets from a float64 origin, the
    /// node's translation); OBJ and OFF keep every digit. f32 or f64 forces it
    /// (STL holds float32 only). The report's file line says what was written.
    #[arg(long, value_enum, value_name = "P", default_value_t = Precision::Auto, help_heading = "Output")]
    pub precision: Precision,
    /// Also write the report as JSON to this file (not the input nor the
    /// output; layout: host/report.schema.json); - writes it to standard
    /// output and the text to standard error.
    #[arg(long, value_name = "JSON", help_heading = "Output")]
    pub report: Option<PathBuf>,
    /// Write the mesh even when it has no faces, or only faces without area
    /// (a run that would give one fails otherwise, nothing written).
    #[arg(long, help_heading = "Output")]
    pub allow_empty: bool,
    #[command(flatten)]
    pub memory: MemoryArgs,
    /// No progress bar.
    #[arg(short, long, help_heading = "Run")]
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

/// A mesh made from a command's input, before anything is written: what
/// [`run`] writes and [`reconstruct`] hands to a library caller.
struct Made {
    /// The input's name, for messages.
    name: String,
    params: Params,
    /// Vertices in file coordinates, in `f64`.
    vertices: Vec<[f64; 3]>,
    triangles: Vec<[u32; 3]>,
    /// Each vertex's colour (its cluster's mean), when the input has colours.
    colors: Option<Vec<[u8; 3]>>,
    /// Bounding-box diagonal of the points core worked on, in file units.
    diagonal: f64,
    /// Points core worked on.
    points: usize,
    input: InputReport,
    params_report: ParamsReport,
    clustering: ClusteringReport,
    meshing: MeshingReport,
    meshing_stats: MeshingStats,
    peaks: StagePeaks,
    arena_reserved: usize,
    arena_needed: usize,
}

/// Read and clean `cmd`'s input and reconstruct it.
fn make(cmd: &Cmd, clock: &mut StageClock) -> Result<Made, String> {
    at_most(
        "--mesh-bytes-per-cluster",
        cmd.mesh.mesh_bytes_per_cluster.into(),
        MAX_MESH_BYTES_PER_CLUSTER.into(),
        "bytes per cluster",
    )?;
    let params = cmd.params();
    params.meshable().map_err(unmeshable)?;
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
    } = read_and_clean(&cmd.input, &cmd.memory, &params, bytes, clock)?;
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
        clock,
    );
    let out = out.map_err(|e| match e {
        Error::MeshCapacity { .. } => format!(
            "{}: {e} (--mesh-bytes-per-cluster, now {}; {} points, {:.1} per cluster of the \
             cap {})",
            input.name,
            params.mesh_capacity_per_cluster(),
            input.points.len(),
            input.points.len() as f64 / f64::from(params.cluster_cap().max(1)),
            params.cluster_cap()
        ),
        Error::ArenaTooSmall { .. } | Error::ArenaTooSmallForMeshing { .. } => {
            format!("{}: {e} (--memory)", input.name)
        }
        e => format!("{}: {e}", input.name),
    })?;
    let diagonal = out.clustered.bounds.diag as f64 * input.frame.scale;
    // The vertices in file coordinates, in f64; how a file holds them
    // depends on how far from the origin they lie.
    let vertices: Vec<[f64; 3]> = out
        .mesh
        .vertices
        .iter()
        .map(|&v| input.frame.to_file(v))
        .collect();
    let colors = input
        .colors
        .as_ref()
        .map(|c| vertex_colors(out.clustered.clusters.labels, c, out.mesh.vertex_cluster));
    let cs = &out.clustered.stats;
    Ok(Made {
        name: input.name.clone(),
        params,
        vertices,
        triangles: out.mesh.triangles.to_vec(),
        colors,
        diagonal,
        points: input.points.len(),
        input: InputReport::new(
            &cmd.input,
            &input,
            points_read,
            stats.as_ref(),
            &params,
            diagonal,
        ),
        params_report: ParamsReport::new(&params, true, RunParams::of(&cmd.memory)),
        clustering: ClusteringReport::new(&cs.cluster, &params, input.points.len()),
        meshing: MeshingReport::new(&out.meshing, params.max_error),
        meshing_stats: out.meshing,
        peaks: StagePeaks {
            cleaning: stats.map(|s| s.peak),
            neighbours: cs.peak_neighbours,
            quadrics: cs.peak_quadrics,
            clustering: cs.peak_clustering,
            meshing: Some(out.meshing.peak),
        },
        arena_reserved,
        arena_needed: bytes.needed(
            &input,
            points_read,
            &params,
            cs.reverse_edges as usize,
            searched,
        ),
    })
}

impl Made {
    /// An error when the mesh checked in `check` has no face with area and
    /// `allow_empty` is off, saying what the caller does instead (`done`:
    /// "; nothing written" for the CLI) and how to ask for it anyway
    /// (`allow`); otherwise why it is empty, if it is.
    fn refuse_empty(
        &self,
        check: &MeshCheck,
        allow_empty: bool,
        done: &str,
        allow: &str,
    ) -> Result<Option<String>, String> {
        match empty(check, &self.meshing_stats) {
            None => Ok(None),
            Some(why) if allow_empty => Ok(Some(why)),
            Some(why) => Err(format!(
                "{}: {why}{done} ({}; {allow} anyway)",
                self.name,
                empty_advice(self.points, &self.params)
            )),
        }
    }

    /// The run's report, the clock read now; `file` is what was written
    /// (`None`: nothing, the mesh went to a library caller), `output` where.
    fn report(
        self,
        clock: &StageClock,
        check: MeshCheck,
        file: Option<FileReport>,
        output: &std::path::Path,
    ) -> ReconstructReport {
        ReconstructReport {
            header: Header::new("reconstruct"),
            input: self.input,
            params: self.params_report,
            clustering: self.clustering,
            meshing: self.meshing,
            run: RunReport::new(
                clock,
                self.peaks,
                self.arena_reserved,
                self.arena_needed,
                output,
            ),
            mesh: check,
            file,
        }
    }
}

/// Run the command.
pub fn run(cmd: &Cmd) -> Result<(), String> {
    let format = MeshFormat::from_path(&cmd.output)?;
    format
        .coords(cmd.precision, false)
        .map_err(|e| format!("{}: {e}", cmd.output.display()))?;
    check_outputs(
        cmd.input.input.as_deref(),
        &cmd.output,
        cmd.report.as_deref(),
    )?;
    let mut clock = StageClock::new(!cmd.quiet).with_threads(cmd.memory.threads());
    let made = make(cmd, &mut clock)?;
    let vertices = &made.vertices;
    let triangles = &made.triangles[..];
    let allowed = AUTO_F32_SHARE * tolerance(&made.params) * made.diagonal;
    let layout = MeshLayout::choose(format, cmd.precision, vertices, allowed)
        .map_err(|e| format!("{}: {e}", cmd.output.display()))?;
    let normals = format
        .has_vertex_normals()
        .then(|| vertex_normals(vertices, triangles));
    let colors = made.colors.as_deref().filter(|_| format.has_colors());
    let file = FileReport::new(
        &layout,
        cmd.precision,
        vertices,
        allowed,
        normals.is_some(),
        colors.is_some(),
    );
    // The check is of the mesh as the file holds it, not of a more precise one.
    let stored: Vec<[f64; 3]> = vertices.iter().map(|&p| layout.stored(p)).collect();
    let check = clock.time_with_tasks("check", |run| MeshCheck::new_with(&stored, triangles, run));
    drop(stored);
    let allow = "--allow-empty writes it";
    if let Some(why) = made.refuse_empty(&check, cmd.allow_empty, "; nothing written", allow)? {
        stdout::warn(format_args!(
            "warning: {}: {why}; written as asked (--allow-empty)",
            made.name
        ));
    }
    let mesh = MeshOut {
        vertices,
        triangles,
        normals: normals.as_deref(),
        colors,
    };
    let staged = clock.time("write", || {
        stage_to(&cmd.output, |w| write_mesh(w, &layout, &mesh))
    })?;
    let (name, max_error) = (made.name.clone(), made.params.max_error);
    let report = made.report(&clock, check, Some(file), &cmd.output);
    for warning in report.warnings(&name, max_error) {
        stdout::warn(format_args!("warning: {warning}"));
    }
    if let Some(file) = report.file.as_ref().filter(|f| f.coarser_than_auto()) {
        stdout::warn(format_args!(
            "warning: {}: {} holds float32 coordinates, which moved vertices by up to {:.3e} \
             (float32 steps {:.3e} at the largest coordinate, over the {:.3e} that \
             --precision auto allows); {}",
            cmd.output.display(),
            format.name().to_ascii_uppercase(),
            file.rounding_max,
            file.f32_step,
            file.f32_step_allowed,
            if format == MeshFormat::Stl {
                "write .ply, .obj or .glb to keep them"
            } else {
                "--precision auto or f64 keeps them"
            }
        ));
    }
    publish(
        &report.text(),
        &cmd.output,
        staged,
        cmd.report.as_deref(),
        || report_json(&report),
    )
}

/// A mesh reconstructed for a library caller (the Python module): nothing
/// read from or written to a file unless the command's input names one.
pub struct Reconstructed {
    /// Vertices in the input's coordinates.
    pub vertices: Vec<[f64; 3]>,
    /// Triangles, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
    /// Each vertex's colour (its cluster's mean), when the input has colours.
    pub colors: Option<Vec<[u8; 3]>>,
    /// The report as `--report` writes it (without its `file` part).
    pub report_json: String,
    /// What the CLI would print as warnings, without `warning: `.
    pub warnings: Vec<String>,
}

/// What [`run`] makes of `cmd`, handed back instead of written: the same mesh
/// (in `f64`) and report, and the same errors but for the output's.
pub fn reconstruct(cmd: &Cmd) -> Result<Reconstructed, String> {
    let mut clock = StageClock::new(false).with_threads(cmd.memory.threads());
    let made = make(cmd, &mut clock)?;
    let check = clock.time("check", || MeshCheck::new(&made.vertices, &made.triangles));
    made.refuse_empty(&check, cmd.allow_empty, "", "allow_empty returns it")?;
    let mut made = made;
    let vertices = std::mem::take(&mut made.vertices);
    let triangles = std::mem::take(&mut made.triangles);
    let colors = made.colors.take();
    let (name, max_error) = (made.name.clone(), made.params.max_error);
    let report = made.report(&clock, check, None, std::path::Path::new(""));
    Ok(Reconstructed {
        vertices,
        triangles,
        colors,
        warnings: report.warnings(&name, max_error),
        report_json: report_json(&report)?,
    })
}

/// The error for parameters under which no mesh can be made, in the
/// options' names.
fn unmeshable(u: Unmeshable) -> String {
    match u {
        Unmeshable::TooFewClusters { clusters } => format!(
            "--clusters {clusters}: {clusters} clusters cannot enclose a volume (the mesh's \
             vertices are the clusters' generators, and the least closed surface has \
             {MIN_MESH_CLUSTERS}); use --clusters {MIN_MESH_CLUSTERS} or more"
        ),
        Unmeshable::NoScore => "--fitting 0 and --coverage 0: every facet would score 0 and \
             none be selected, so the mesh would be empty; give --fitting or --coverage a \
             positive weight"
            .to_string(),
        Unmeshable::EpsilonBelowPrecision { epsilon } => format!(
            "--epsilon {epsilon:e} is below {MIN_EPSILON:e}, the precision of the float32 \
             coordinates core works in: no point could be told to lie within it of a facet, \
             so no facet would have support; use --epsilon {MIN_EPSILON:e} or more (default {})",
            Params::default().epsilon
        ),
        u => format!("no mesh can be made: {u}"),
    }
}

/// Why the mesh checked in `check` is not worth writing, when it has no face
/// with area: none at all, or only degenerate ones (`meshing`'s candidates
/// say which step gave none).
fn empty(check: &MeshCheck, meshing: &MeshingStats) -> Option<String> {
    let t = &check.topology;
    if t.faces > t.degenerate_faces {
        return None;
    }
    Some(if t.faces == 0 && meshing.candidate_facets == 0 {
        "the mesh has no faces: the clusters' neighbour graph gave no candidate facet".to_string()
    } else if t.faces == 0 {
        format!(
            "the mesh has no faces: none of the {} candidate facets was selected",
            meshing.candidate_facets
        )
    } else {
        format!("the mesh's {} faces all have zero area", t.faces)
    })
}

/// What to change after [`empty`], for a run on `points` points: more points
/// per cluster when there are fewer than `--knn` (facets are scored by the
/// points near them), else a wider support distance.
fn empty_advice(points: usize, params: &Params) -> String {
    let clusters = params.clusters;
    let fewer = if clusters > MIN_MESH_CLUSTERS {
        " or fewer --clusters"
    } else {
        ""
    };
    let per_cluster = points as f64 / f64::from(clusters.max(1));
    if per_cluster < params.k as f64 {
        format!(
            "{points} points make {per_cluster:.1} per cluster of --clusters {clusters}, too \
             few to support facets: give more points{fewer}"
        )
    } else {
        format!("try a larger --epsilon{fewer}")
    }
}

/// The tolerance `--precision auto` measures `float32` against, fraction of
/// the diagonal: `--tolerance`, or its default when splitting is off (0).
fn tolerance(params: &Params) -> f64 {
    let t = if params.tolerance > 0.0 {
        params.tolerance
    } else {
        Params::default().tolerance
    };
    f64::from(t)
}

/// The report of a run, filled once from its results: its JSON is this struct
/// serialised, its text reads only this.
#[derive(Serialize)]
struct ReconstructReport {
    #[serde(flatten)]
    header: Header,
    #[serde(flatten)]
    input: InputReport,
    params: ParamsReport,
    #[serde(flatten)]
    clustering: ClusteringReport,
    #[serde(flatten)]
    meshing: MeshingReport,
    #[serde(flatten)]
    run: RunReport,
    /// The checks of the mesh written.
    mesh: MeshCheck,
    /// The file written: format, coordinates, normals and colours (absent
    /// when the mesh went to a library caller).
    #[serde(skip_serializing_if = "Option::is_none")]
    file: Option<FileReport>,
}

/// What meshing gave (core's [`MeshingStats`], under the report's names):
/// candidates, the selection, the mesh, its repairs and its distance to the
/// points (relative to the diagonal).
#[derive(Clone, Copy, Debug, Serialize)]
struct MeshingReport {
    refine_rounds: u32,
    gap_rounds: u32,
    refine_added: u32,
    candidate_edges: u32,
    candidate_facets: u32,
    degenerate_facets: u32,
    fold_groups: u32,
    merged_generators: u32,
    mean_supports: f32,
    solver_optimal: bool,
    solver_gap: f64,
    solver_nodes: u64,
    solver_objective: f64,
    solver_upper_bound: f64,
    solver_components: u32,
    solver_largest_component: u32,
    solver_forced: u32,
    vertices: u32,
    faces: u32,
    boundary_edges: u32,
    components: u32,
    non_orientable_components: u32,
    pinches_repaired: u32,
    thin_parts_joined: u32,
    bubbles_removed: u32,
    tangled_pairs: u32,
    split_vertices: u32,
    border_clusters: u32,
    open_loops: u32,
    holes_filled: u32,
    filled_faces: u32,
    holes_left: u32,
    orientation_repairs: u32,
    inserted_clusters: u32,
    densified: u32,
    uncovered_clusters: u32,
    uncovered_points: u32,
    fit_rounds: u32,
    fitted_vertices: u32,
    fit_reverted: u32,
    distance_max_relative: f32,
    distance_p99_relative: f32,
    distance_mean_relative: f32,
    /// `--max-error` (0: no bound); `max_error_relative` is clustering's.
    error_bound_relative: f32,
    /// Whether every point is within it (absent without a bound).
    #[serde(skip_serializing_if = "Option::is_none")]
    error_bound_met: Option<bool>,
}

impl MeshingReport {
    /// The report of meshing that gave `m` under the error bound `max_error`.
    fn new(m: &MeshingStats, max_error: f32) -> Self {
        let (sel, mesh) = (&m.selection, &m.mesh);
        let d = &mesh.distance;
        MeshingReport {
            refine_rounds: m.refine_rounds,
            gap_rounds: m.gap_rounds,
            refine_added: m.refine_added,
            candidate_edges: m.candidate_edges,
            candidate_facets: m.candidate_facets,
            degenerate_facets: m.degenerate_facets,
            fold_groups: m.fold_groups,
            merged_generators: m.merged_generators,
            mean_supports: m.mean_supports,
            solver_optimal: sel.optimal,
            solver_gap: sel.gap,
            solver_nodes: sel.nodes,
            solver_objective: sel.objective,
            solver_upper_bound: sel.upper_bound,
            solver_components: sel.components,
            solver_largest_component: sel.largest_component,
            solver_forced: sel.forced,
            vertices: mesh.vertices,
            faces: mesh.faces,
            boundary_edges: mesh.boundary_edges,
            components: mesh.components,
            non_orientable_components: mesh.non_orientable,
            pinches_repaired: mesh.pinches_repaired,
            thin_parts_joined: mesh.necks,
            bubbles_removed: mesh.bubbles_removed,
            tangled_pairs: mesh.tangled_pairs,
            split_vertices: mesh.split_vertices,
            border_clusters: m.border_clusters,
            open_loops: mesh.open_loops,
            holes_filled: mesh.holes_filled,
            filled_faces: mesh.filled_faces,
            holes_left: mesh.holes_left,
            orientation_repairs: mesh.repairs,
            inserted_clusters: mesh.inserted_clusters,
            densified: mesh.densified,
            uncovered_clusters: mesh.uncovered_clusters,
            uncovered_points: mesh.uncovered_points,
            fit_rounds: mesh.fit.rounds,
            fitted_vertices: mesh.fit.moved,
            fit_reverted: mesh.fit.reverted,
            distance_max_relative: d.max,
            distance_p99_relative: d.p99,
            distance_mean_relative: d.mean,
            error_bound_relative: max_error,
            error_bound_met: (max_error > 0.0).then_some(d.max <= max_error),
        }
    }

    /// By how much the farthest point exceeds `--max-error` (relative), when
    /// a bound was asked for and not met.
    fn max_error_missed(&self) -> Option<f32> {
        let (max, bound) = (self.distance_max_relative, self.error_bound_relative);
        (bound > 0.0 && max > bound).then_some(max - bound)
    }
}

impl ReconstructReport {
    /// What the run warns about on `name`'s points with `--max-error`
    /// `max_error`: a tolerance the cluster cap left unmet, an error bound not
    /// met.
    fn warnings(&self, name: &str, max_error: f32) -> Vec<String> {
        let (c, m) = (&self.clustering, &self.meshing);
        let mut out = Vec::new();
        if let Some((why, true)) = c.tolerance_unmet(self.params.clustering.split_rounds) {
            out.push(format!(
                "{name}: {why}; largest error {:.3}% of the diagonal",
                c.max_error_relative * 100.0
            ));
        }
        if let Some(over) = m.max_error_missed() {
            out.push(format!(
                "{name}: --max-error {max_error} not met: the farthest point is {:.3}% of the \
                 diagonal from the mesh ({:.3}% over) after {} refinement rounds with {} \
                 clusters: {}",
                m.distance_max_relative * 100.0,
                over * 100.0,
                m.refine_rounds,
                c.clusters,
                self.max_error_stop(),
            ));
        }
        out
    }

    /// Why refinement stopped short of `--max-error`.
    fn max_error_stop(&self) -> &'static str {
        if self.clustering.clusters >= self.clustering.cluster_cap {
            "the cluster cap is reached (raise --max-clusters)"
        } else if self.meshing.refine_rounds >= vsaqem_core::MAX_ERROR_ROUNDS {
            "the most rounds an error bound runs"
        } else {
            "no vertex could be added where the mesh is too far"
        }
    }

    fn fit_text(&self) -> String {
        let m = &self.meshing;
        let densify = format!(
            "densify    {} vertices added where the mesh was farthest from the data\n",
            m.densified
        );
        if m.fit_rounds == 0 {
            return densify + "fit        none (--fit-rounds 0, or no faces)\n";
        }
        densify
            + &format!(
                "fit        {} vertices moved onto the data in {} rounds, {} moves taken back \
                 (a face would turn over or collapse)\n",
                m.fitted_vertices, m.fit_rounds, m.fit_reverted
            )
    }

    fn distance_text(&self) -> String {
        let m = &self.meshing;
        let bound = m.error_bound_relative;
        let bound = match m.max_error_missed() {
            _ if bound <= 0.0 => String::new(),
            None => format!("; bound {:.3}% met", bound * 100.0),
            Some(over) => format!(
                "; bound {:.3}% NOT met ({:.3}% over: {})",
                bound * 100.0,
                over * 100.0,
                self.max_error_stop()
            ),
        };
        format!(
            "distance   points to mesh: max {:.3}%, p99 {:.3}%, mean {:.4}% of the diagonal{bound}\n",
            m.distance_max_relative * 100.0,
            m.distance_p99_relative * 100.0,
            m.distance_mean_relative * 100.0
        )
    }

    fn text(&self) -> String {
        let cl = &self.clustering;
        let m = &self.meshing;
        let solver = if m.solver_optimal {
            format!("optimal ({} nodes)", m.solver_nodes)
        } else {
            format!(
                "node limit reached, gap {:.3}% ({} nodes)",
                m.solver_gap * 100.0,
                m.solver_nodes
            )
        };
        // The mesh as written (core's counts can miss what densifying did
        // at the boundary).
        let t = &self.mesh.topology;
        let closed = if t.boundary_edges == 0 && m.uncovered_clusters == 0 {
            "watertight".to_string()
        } else if t.boundary_edges == 0 {
            format!(
                "closed, but {} clusters ({} points) are not covered",
                m.uncovered_clusters, m.uncovered_points
            )
        } else {
            format!(
                "{} boundary edges, {} uncovered clusters ({} points)",
                t.boundary_edges, m.uncovered_clusters, m.uncovered_points
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
             {}\
             {}\
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
            cl.max_error_relative * 100.0,
            cl.unmet_note(self.params.clustering.split_rounds),
            m.candidate_edges,
            m.candidate_facets,
            m.degenerate_facets,
            m.fold_groups,
            m.merged_generators,
            m.mean_supports,
            m.solver_components,
            m.solver_largest_component,
            m.solver_forced,
            t.vertices,
            t.faces,
            t.components,
            m.inserted_clusters,
            self.fit_text(),
            self.distance_text(),
            m.border_clusters,
            m.open_loops,
            m.holes_filled,
            m.filled_faces,
            m.holes_left,
            m.orientation_repairs,
            m.pinches_repaired,
            m.thin_parts_joined,
            m.bubbles_removed,
            m.split_vertices,
            m.tangled_pairs,
            self.mesh.text(),
            self.file.as_ref().map(FileReport::text).unwrap_or_default(),
            self.run.text(self.input.points, ""),
        )
    }
}
