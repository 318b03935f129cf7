//! The typed report of `cluster` and `reconstruct`, and the parts they share:
//! what every report opens with ([`Header`]), what was read and what cleaning
//! left of it ([`InputReport`], [`CleanReport`]), every parameter the run used
//! ([`ParamsReport`]), clustering's results ([`ClusteringReport`]), what the run
//! took and where it wrote ([`RunReport`]), and the checks of the mesh written
//! ([`MeshCheck`]).
//!
//! Each command's report struct holds these beside its own numbers, filled once
//! from the run's results. Its JSON is that struct serialised (serde), its text
//! reads only that struct, so the two cannot disagree. The JSON's shape is
//! `host/report.schema.json` ([`SCHEMA_VERSION`]); a test validates real
//! reports against it. Numbers that are not finite are written as `null`.

use crate::args::{InputArgs, MemoryArgs};
use crate::eval::{check_solid, check_solid_with, Solid, Topology, Validity};
use crate::input::{Prepared, Source, SAMPLE_SEED};
use crate::io::write::mesh::f32_step;
use crate::io::{is_stdio, stage_to, Coords, MeshLayout, Precision, Staged};
use crate::progress::{StageClock, Timings};
use crate::stdout;
use serde::Serialize;
use std::path::Path;
use vsaqem_core::{CleanStats, ClusterStats, Params, Partition, Task};

/// The version of the reports' JSON layout (`schema_version`): raised when a
/// field is renamed, removed or changes meaning; adding a field keeps it.
pub const SCHEMA_VERSION: u32 = 1;

/// What every report opens with: its layout's version, the tool and the
/// command that wrote it.
#[derive(Clone, Debug, Serialize)]
pub struct Header {
    /// [`SCHEMA_VERSION`].
    pub schema_version: u32,
    /// `"vsaqem"`.
    pub tool: &'static str,
    /// The tool's version (the crate's).
    pub tool_version: &'static str,
    /// The subcommand: `"cluster"` or `"reconstruct"`.
    pub command: &'static str,
}

impl Header {
    /// The header of a report of `command`.
    pub fn new(command: &'static str) -> Self {
        Header {
            schema_version: SCHEMA_VERSION,
            tool: env!("CARGO_PKG_NAME"),
            tool_version: env!("CARGO_PKG_VERSION"),
            command,
        }
    }
}

/// Prints a report's `text`, then puts the run's files in place: `staged`
/// (the run's output, written in full but not committed) and, when
/// `json_path` is given, `json()` (only made when it is asked for), staged
/// before the text is printed. The text goes to stdout, or to stderr when
/// stdout carries the output (`output` or `json_path` is `-`). A stream that
/// cannot be written (closed, full) is an error, and then no file is left:
/// the staged ones are removed, an existing target keeps its old content.
pub fn publish(
    text: &str,
    output: &Path,
    staged: Staged,
    json_path: Option<&Path>,
    json: impl FnOnce() -> Result<String, String>,
) -> Result<(), String> {
    let report = match json_path {
        Some(path) => {
            let body = json()?;
            Some(stage_to(path, |w| w.write_all(body.as_bytes()))?)
        }
        None => None,
    };
    if is_stdio(output) || json_path.is_some_and(is_stdio) {
        stdout::eprint(text)?;
    } else {
        stdout::print(text)?;
    }
    for file in std::iter::once(staged).chain(report) {
        file.commit().map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// `report` as indented JSON, ending in a newline.
pub fn report_json(report: &impl Serialize) -> Result<String, String> {
    serde_json::to_string_pretty(report)
        .map(|s| s + "\n")
        .map_err(|e| format!("the report cannot be written as JSON: {e}"))
}

/// Where the points of a run with `args` come from.
pub fn source(args: &InputArgs) -> Source {
    if let Some(given) = &args.given {
        return Source::Array {
            points: given.points(),
        };
    }
    Source::of(
        args.input.as_deref(),
        args.sample,
        args.points,
        args.noise,
        SAMPLE_SEED,
    )
}

/// What was read, and what the cleaning pre-pass left for core.
#[derive(Clone, Debug, Serialize)]
pub struct InputReport {
    /// Where the points come from.
    pub input: Source,
    /// Points read, invalid ones skipped, before merging duplicates and
    /// cleaning.
    pub points_read: usize,
    /// Points the reader skipped as invalid (NaN or infinite coordinates in a
    /// PCD, LAS or E57 file, where the format's convention is to skip them),
    /// not counted in `points_read`.
    pub invalid_skipped: usize,
    /// Points read at the position of an earlier point, bit for bit, and
    /// merged into it (counted in `points_read`, not in `points`).
    pub duplicates_merged: usize,
    /// Points after cleaning: those core worked on.
    pub points: usize,
    /// Whether the input gave normals (else core estimates them).
    pub normals_given: bool,
    /// Bounding-box diagonal of the points core worked on, in file units.
    pub diagonal: f64,
    /// The cleaning pre-pass.
    #[serde(flatten)]
    pub clean: CleanReport,
}

impl InputReport {
    /// The report of the points of a run with `args`, as cleaning left them
    /// (`input`): `distinct` points before cleaning (after merging exact
    /// duplicates), `clean` what cleaning with `params` removed (`None`: it did
    /// not run), `diagonal` in file units.
    pub fn new(
        args: &InputArgs,
        input: &Prepared,
        distinct: usize,
        clean: Option<&CleanStats>,
        params: &Params,
        diagonal: f64,
    ) -> Self {
        InputReport {
            input: source(args),
            points_read: distinct + input.duplicates,
            invalid_skipped: input.invalid,
            duplicates_merged: input.duplicates,
            points: input.points.len(),
            normals_given: input.normals.is_some(),
            diagonal,
            clean: CleanReport::new(clean, params),
        }
    }

    /// The `input` and `clean` lines.
    pub fn text(&self) -> String {
        let normals = if self.normals_given {
            "normals given"
        } else {
            "normals by PCA"
        };
        let invalid = match self.invalid_skipped {
            0 => String::new(),
            n => format!(" ({n} invalid skipped)"),
        };
        let duplicates = match self.duplicates_merged {
            0 => String::new(),
            n => format!(
                ", {} exact duplicates merged ({} distinct)",
                n,
                self.points_read - n
            ),
        };
        format!(
            "input      {}: {} points{invalid}{duplicates}, {normals}, bounding-box diagonal {:.6}\n\
             clean      {}\n",
            self.input,
            self.points_read,
            self.diagonal,
            self.clean.text(self.points, self.points_read - self.duplicates_merged),
        )
    }
}

/// The cleaning pre-pass: its settings and what its filters removed (all 0
/// when both filters are off).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct CleanReport {
    /// `--outliers`, in standard deviations (0: filter off).
    pub outlier_sigma: f32,
    /// `--min-fragment`, in points (0: filter off).
    pub min_fragment: u32,
    /// Points removed by the outlier filter.
    pub outliers_removed: u32,
    /// Pieces dropped as fragments.
    pub fragments_dropped: u32,
    /// Points in the dropped fragments.
    pub fragment_points: u32,
    /// Pieces kept (0 when the fragment filter is off).
    pub pieces: u32,
}

impl CleanReport {
    /// The report of cleaning with `params`, which gave `stats` (`None`: it did
    /// not run).
    pub fn new(stats: Option<&CleanStats>, params: &Params) -> Self {
        let s = stats.copied().unwrap_or_default();
        CleanReport {
            outlier_sigma: params.outlier_sigma,
            min_fragment: params.min_fragment,
            outliers_removed: s.outliers,
            fragments_dropped: s.fragments,
            fragment_points: s.fragment_points,
            pieces: s.pieces,
        }
    }

    /// Whether a filter ran.
    pub fn ran(&self) -> bool {
        self.outlier_sigma > 0.0 || self.min_fragment > 0
    }

    /// The `clean` line without its label, when `kept` of the `read` points were
    /// kept.
    pub fn text(&self, kept: usize, read: usize) -> String {
        if !self.ran() {
            return "off".to_string();
        }
        let outliers = if self.outlier_sigma > 0.0 {
            format!(
                "{} removed (over {} standard deviations)",
                count(self.outliers_removed.into(), "outlier"),
                self.outlier_sigma
            )
        } else {
            "outlier filter off".to_string()
        };
        let (fragments, pieces) = if self.min_fragment > 0 {
            (
                format!(
                    "{} dropped ({}; pieces under {} points)",
                    count(self.fragments_dropped.into(), "fragment"),
                    count(self.fragment_points.into(), "point"),
                    self.min_fragment
                ),
                format!(" in {}", count(self.pieces.into(), "piece")),
            )
        } else {
            ("fragment filter off".to_string(), String::new())
        };
        format!("{outliers}, {fragments}; {kept} of {read} points kept{pieces}")
    }
}

/// `"1 point"`, `"3 points"`.
fn count(n: u64, what: &str) -> String {
    match n {
        1 => format!("1 {what}"),
        n => format!("{n} {what}s"),
    }
}

/// Every parameter a run used, by the heading of its option: core's
/// [`Params`] under core's field names (`k` is `--knn`), and the host's.
#[derive(Clone, Debug, Serialize)]
pub struct ParamsReport {
    /// The cleaning pre-pass.
    pub cleaning: CleaningParams,
    /// Neighbours, clustering and splitting.
    pub clustering: ClusteringParams,
    /// Meshing (only in the reports of commands that mesh).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub meshing: Option<MeshingParams>,
    /// How the run ran.
    pub run: RunParams,
}

/// [`Params`] of the cleaning pre-pass.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct CleaningParams {
    /// [`Params::outlier_sigma`].
    pub outlier_sigma: f32,
    /// [`Params::min_fragment`].
    pub min_fragment: u32,
    /// [`Params::smooth_rounds`].
    pub smooth_rounds: u32,
}

/// [`Params`] of neighbours and clustering.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct ClusteringParams {
    /// [`Params::k`].
    pub k: usize,
    /// [`Params::clusters`].
    pub clusters: u32,
    /// [`Params::max_clusters`] (0: twice `clusters`).
    pub max_clusters: u32,
    /// [`Params::iterations`].
    pub iterations: u32,
    /// [`Params::split_iterations`].
    pub split_iterations: u32,
    /// [`Params::split_rounds`].
    pub split_rounds: u32,
    /// [`Params::tolerance`].
    pub tolerance: f32,
    /// [`Params::lambda`].
    pub lambda: f32,
    /// [`Params::seed`].
    pub seed: u64,
    /// [`Params::partition`]: `auto`, `grow` or `sweep`.
    pub partition: &'static str,
}

/// [`Params`] of meshing.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct MeshingParams {
    /// [`Params::epsilon`].
    pub epsilon: f32,
    /// [`Params::alpha_scale`].
    pub alpha_scale: f32,
    /// [`Params::fitting_weight`].
    pub fitting_weight: f32,
    /// [`Params::coverage_weight`].
    pub coverage_weight: f32,
    /// [`Params::border_penalty`].
    pub border_penalty: f32,
    /// [`Params::max_hole`].
    pub max_hole: u32,
    /// [`Params::border_angle`].
    pub border_angle: f32,
    /// [`Params::node_limit`].
    pub node_limit: u64,
    /// [`Params::fit_rounds`].
    pub fit_rounds: u32,
    /// [`Params::densify`].
    pub densify: f32,
    /// [`Params::refine_rounds`].
    pub refine_rounds: u32,
    /// [`Params::refine_beyond`].
    pub refine_beyond: f32,
    /// [`Params::max_error`].
    pub max_error: f32,
    /// [`Params::mesh_bytes_per_cluster`] as given (0: the default).
    pub mesh_bytes_per_cluster: u32,
    /// The meshing memory per cluster used ([`Params::mesh_capacity_per_cluster`]).
    pub mesh_bytes_per_cluster_used: usize,
}

/// The host's settings of a run.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct RunParams {
    /// Threads core's parallel stages ran on.
    pub threads: usize,
    /// `--memory` in bytes; `null` when not given (the arena is what the run
    /// can need: `arena_reserved_bytes`).
    pub memory: Option<usize>,
}

impl RunParams {
    /// The settings `args` give.
    pub fn of(args: &MemoryArgs) -> Self {
        RunParams {
            threads: args.threads(),
            memory: args.memory,
        }
    }
}

impl ParamsReport {
    /// Every field of `params`, with the meshing ones when `meshing`, and the
    /// host's `run` settings. A field added to [`Params`] fails to compile
    /// here until the report echoes it.
    pub fn new(params: &Params, meshing: bool, run: RunParams) -> Self {
        let Params {
            k,
            clusters,
            max_clusters,
            iterations,
            split_iterations,
            split_rounds,
            tolerance,
            lambda,
            seed,
            partition,
            epsilon,
            alpha_scale,
            fitting_weight,
            coverage_weight,
            border_penalty,
            max_hole,
            border_angle,
            node_limit,
            fit_rounds,
            densify,
            refine_rounds,
            max_error,
            refine_beyond,
            mesh_bytes_per_cluster,
            outlier_sigma,
            min_fragment,
            smooth_rounds,
        } = *params;
        ParamsReport {
            cleaning: CleaningParams {
                outlier_sigma,
                min_fragment,
                smooth_rounds,
            },
            clustering: ClusteringParams {
                k,
                clusters,
                max_clusters,
                iterations,
                split_iterations,
                split_rounds,
                tolerance,
                lambda,
                seed,
                partition: match partition {
                    Partition::Auto => "auto",
                    Partition::Grow => "grow",
                    Partition::Sweep => "sweep",
                },
            },
            meshing: meshing.then_some(MeshingParams {
                epsilon,
                alpha_scale,
                fitting_weight,
                coverage_weight,
                border_penalty,
                max_hole,
                border_angle,
                node_limit,
                fit_rounds,
                densify,
                refine_rounds,
                refine_beyond,
                max_error,
                mesh_bytes_per_cluster,
                mesh_bytes_per_cluster_used: params.mesh_capacity_per_cluster(),
            }),
            run,
        }
    }
}

/// What clustering gave, in both reports: counts, and its largest error
/// against the tolerance (relative to the diagonal).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct ClusteringReport {
    /// Clusters at the end.
    pub clusters: u32,
    /// Generators placed by the initialisation.
    pub initial_clusters: u32,
    /// Generators added by splitting.
    pub splits: u32,
    /// Partition + update passes run in total.
    pub passes: u32,
    /// Splitting batches accepted.
    pub split_batches: u32,
    /// Splitting batches undone because they raised the largest error.
    pub split_batches_undone: u32,
    /// Whether the last passes ended because no generator moved.
    pub converged: bool,
    /// Largest point error against its cluster's generator.
    pub max_error_relative: f32,
    /// `--tolerance`, as asked.
    pub tolerance_relative: f32,
    /// The tolerance used (never below 4 times the noise floor).
    pub tolerance_used_relative: f32,
    /// The noise floor of the points' planes.
    pub noise_floor_relative: f32,
    /// Whether the largest error is within the tolerance used.
    pub tolerance_met: bool,
    /// The most clusters splitting may reach (the cap, at most the points).
    pub cluster_cap: u32,
}

impl ClusteringReport {
    /// The report of clustering `points` points with `params`, which gave `c`.
    pub fn new(c: &ClusterStats, params: &Params, points: usize) -> Self {
        ClusteringReport {
            clusters: c.clusters,
            initial_clusters: c.initial_clusters,
            splits: c.splits,
            passes: c.passes,
            split_batches: c.split_rounds,
            split_batches_undone: c.rejected_batches,
            converged: c.converged,
            max_error_relative: c.max_error,
            tolerance_relative: params.tolerance,
            tolerance_used_relative: c.tolerance,
            noise_floor_relative: c.noise,
            tolerance_met: c.max_error <= c.tolerance,
            cluster_cap: params
                .cluster_cap()
                .min(u32::try_from(points).unwrap_or(u32::MAX)),
        }
    }

    /// When clustering ended with its largest error above the tolerance used:
    /// what the report says, with why splitting stopped (the cluster cap, or
    /// all `split_rounds` batches run), and whether the cap is the reason
    /// (then the run warns on stderr too: more clusters were wanted than
    /// allowed).
    pub fn tolerance_unmet(&self, split_rounds: u32) -> Option<(String, bool)> {
        let (max, tol) = (self.max_error_relative, self.tolerance_used_relative);
        if max.is_nan() || max <= tol || tol <= 0.0 {
            return None;
        }
        let cap = self.cluster_cap;
        // Splitting's own clusters: refinement runs after it (and may go beyond
        // the cap at the rims of gaps).
        let at_cap = self.initial_clusters.saturating_add(self.splits) >= cap;
        let why = if at_cap {
            format!("the cluster cap {cap} is reached (raise --max-clusters)")
        } else if self.split_batches + self.split_batches_undone >= split_rounds {
            format!("splitting ran its {split_rounds} batches (--split-rounds)")
        } else {
            "no split was left that lowers it".to_string()
        };
        let text = format!("tolerance {:.3}% not met: {why}", tol * 100.0);
        Some((text, at_cap))
    }

    /// `"; why"` when the tolerance is not met, else nothing.
    pub fn unmet_note(&self, split_rounds: u32) -> String {
        self.tolerance_unmet(split_rounds)
            .map_or(String::new(), |(why, _)| format!("; {why}"))
    }
}

/// What a run took (time, memory) and where it wrote.
#[derive(Clone, Debug, Serialize)]
pub struct RunReport {
    /// Time per stage and in total, in milliseconds.
    pub time_ms: Timings,
    /// Arena peak in bytes.
    pub arena_peak_bytes: usize,
    /// Arena size in bytes (the `--memory` budget, or what the run can need).
    pub arena_reserved_bytes: usize,
    /// The least `--memory` this run would have taken: what core bounds for
    /// this cloud once its neighbour graph is known, and the pre-passes.
    pub arena_needed_bytes: usize,
    /// The arena's peak at the end of each stage.
    pub arena_peak_by_stage_bytes: StagePeaks,
    /// The process's peak resident memory (Linux's `VmHWM`), `null` where it
    /// cannot be read.
    pub peak_rss_bytes: Option<u64>,
    /// The output file.
    pub output: String,
}

/// The arena's peak at the end of each stage, in bytes: it only grows, but
/// for cleaning, which runs in a buffer of its own before the run.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct StagePeaks {
    /// The cleaning pre-pass's own buffer (`null`: cleaning was off).
    pub cleaning: Option<usize>,
    /// After the neighbour search.
    pub neighbours: usize,
    /// After the quadrics.
    pub quadrics: usize,
    /// After clustering.
    pub clustering: usize,
    /// After meshing (absent where the command does not mesh).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub meshing: Option<usize>,
}

impl RunReport {
    /// The report of a run timed by `clock` (taken now: call it last), with an
    /// arena of `arena_reserved` bytes that peaked as `peaks` say where
    /// `arena_needed` would have done, written to `output`.
    pub fn new(
        clock: &StageClock,
        peaks: StagePeaks,
        arena_reserved: usize,
        arena_needed: usize,
        output: &Path,
    ) -> Self {
        let arena_peak = [peaks.clustering, peaks.meshing.unwrap_or(0)]
            .into_iter()
            .max()
            .unwrap_or(0);
        RunReport {
            time_ms: clock.timings(),
            arena_peak_bytes: arena_peak,
            arena_reserved_bytes: arena_reserved,
            arena_needed_bytes: arena_needed,
            arena_peak_by_stage_bytes: peaks,
            peak_rss_bytes: peak_rss_bytes(),
            output: output.display().to_string(),
        }
    }

    /// The `time`, `memory` and `output` lines: `points` are those core worked on,
    /// `note` follows the output's name.
    pub fn text(&self, points: usize, note: &str) -> String {
        let p = &self.arena_peak_by_stage_bytes;
        let mut stages = Vec::new();
        if let Some(c) = p.cleaning {
            stages.push(format!("cleaning {c}"));
        }
        stages.push(format!("neighbours {}", p.neighbours));
        stages.push(format!("quadrics {}", p.quadrics));
        stages.push(format!("clustering {}", p.clustering));
        if let Some(m) = p.meshing {
            stages.push(format!("meshing {m}"));
        }
        let rss = self.peak_rss_bytes.map_or(String::new(), |b| {
            format!("; process peak {:.1} MiB", b as f64 / (1u64 << 20) as f64)
        });
        format!(
            "time       {}\n\
             memory     arena peak {} bytes ({:.1} bytes/point), {} reserved, {} needed{rss}\n\
             \x20          arena peak by stage: {}\n\
             output     {}{note}\n",
            self.time_ms.summary(),
            self.arena_peak_bytes,
            self.arena_peak_bytes as f64 / points as f64,
            self.arena_reserved_bytes,
            self.arena_needed_bytes,
            stages.join(", "),
            self.output,
        )
    }
}

/// The process's peak resident set size, from `/proc/self/status` (`VmHWM`);
/// `None` where there is no such file.
pub fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line
        .trim_start_matches("VmHWM:")
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .ok()?;
    kib.checked_mul(1024)
}

/// The checks of the mesh a run writes, on its vertices as the file holds them
/// (`crate::eval::check_solid`, the test of `vsaqem eval`): its combinatorics
/// (the fields of [`Topology`]), its validity (those of [`Validity`]), and the
/// verdicts.
#[derive(Clone, Debug, Serialize)]
pub struct MeshCheck {
    /// Closed: faces, and every edge has exactly two of them.
    pub watertight: bool,
    /// Edge- and vertex-manifold: no edge with more than two faces, no vertex
    /// whose faces form more than one fan.
    pub manifold: bool,
    /// Every edge with two faces is traversed in opposite directions by them.
    pub oriented: bool,
    /// A valid solid (`vsaqem eval`'s verdict without an expected genus):
    /// watertight, manifold, oriented, no degenerate or duplicate face, no two
    /// faces crossing or touching beyond a shared edge or vertex, no two
    /// vertices at one position, no folded edge, no bubble.
    pub valid_solid: bool,
    /// Combinatorics: counts, components, Euler characteristic.
    #[serde(flatten)]
    pub topology: Topology,
    /// Geometric checks and the genus of each closed component.
    #[serde(flatten)]
    pub validity: Validity,
    /// The sum of `genus`: handles of the closed components.
    pub handles: u64,
}

impl MeshCheck {
    /// Checks the mesh (`vertices` as the file holds them, `triangles`).
    /// Cost: that of `crate::eval::check_solid`, O(F log F) and the
    /// self-intersection test.
    pub fn new(vertices: &[[f64; 3]], triangles: &[[u32; 3]]) -> Self {
        Self::from_solid(check_solid(vertices, triangles))
    }

    /// [`MeshCheck::new`], its self-intersection test and topology handed to
    /// `run` as two tasks ([`check_solid_with`]).
    pub fn new_with(
        vertices: &[[f64; 3]],
        triangles: &[[u32; 3]],
        run: &dyn Fn(&mut [&mut dyn Task]),
    ) -> Self {
        Self::from_solid(check_solid_with(vertices, triangles, run))
    }

    fn from_solid(solid: Solid) -> Self {
        let Solid { topology: t, .. } = &solid;
        MeshCheck {
            watertight: t.faces > 0 && t.boundary_edges == 0 && t.non_manifold_edges == 0,
            manifold: t.non_manifold_edges == 0 && t.non_manifold_vertices == 0,
            oriented: t.inconsistent_edges == 0,
            valid_solid: solid.is_valid_solid(None),
            handles: solid.validity.handles(),
            topology: solid.topology,
            validity: solid.validity,
        }
    }

    /// The `check` line.
    pub fn text(&self) -> String {
        let (t, v) = (&self.topology, &self.validity);
        let yes = |b: bool, word: &'static str| if b { word } else { "" };
        let shape: Vec<&str> = [
            yes(self.watertight, "watertight"),
            yes(!self.watertight, "not closed"),
            yes(self.manifold, "manifold"),
            yes(!self.manifold, "not manifold"),
            yes(self.oriented, "oriented"),
            yes(!self.oriented, "not oriented"),
        ]
        .into_iter()
        .filter(|w| !w.is_empty())
        .collect();
        let genus: Vec<String> = v.genus.iter().map(u32::to_string).collect();
        format!(
            "check      valid solid: {} ({}; Euler {}, genus [{}]; {} crossing face pairs, \
             {} coincident vertices, {} folded edges, {} degenerate faces, {} bubbles)\n",
            if self.valid_solid { "yes" } else { "no" },
            shape.join(", "),
            t.euler,
            genus.join(", "),
            v.crossings_text(),
            v.coincident_vertices,
            v.folded_edges,
            t.degenerate_faces,
            v.bubbles,
        )
    }
}

/// The mesh file a run wrote: its format, how it holds coordinates and how
/// far that moved the vertices, and what it carries beside them.
#[derive(Clone, Debug, Serialize)]
pub struct FileReport {
    /// `ply`, `obj`, `off`, `stl` or `glb`.
    pub format: &'static str,
    /// `--precision` as given: `auto`, `f32` or `f64`.
    pub precision: &'static str,
    /// How the file holds coordinates: `f32`, `f64`, or `f32_offset` (GLB:
    /// `float32` offsets from `origin`, the node's translation).
    pub coordinates: Coords,
    /// The origin of `f32_offset` coordinates, in file units (`null` otherwise).
    pub origin: Option<[f64; 3]>,
    /// The spacing of `float32` values at the mesh's largest coordinate, in
    /// file units: what rounding to `float32` moves a coordinate by, at most
    /// half of it.
    pub f32_step: f64,
    /// The largest such spacing `--precision auto` writes as `float32`: 1 % of
    /// the tolerance times the diagonal, in file units.
    pub f32_step_allowed: f64,
    /// The farthest a vertex is from its position as stored, in file units (0
    /// where the file keeps every digit).
    pub rounding_max: f64,
    /// Whether the file holds a normal at each vertex (from the mesh).
    pub normals: bool,
    /// Whether the file holds a colour at each vertex (the input's colours,
    /// averaged per cluster).
    pub colors: bool,
}

impl FileReport {
    /// The report of `vertices` (file coordinates) written in `layout`, chosen
    /// under `precision` with `allowed` the largest `float32` step `auto`
    /// takes; `normals` and `colors` say what the file holds beside them.
    pub fn new(
        layout: &MeshLayout,
        precision: Precision,
        vertices: &[[f64; 3]],
        allowed: f64,
        normals: bool,
        colors: bool,
    ) -> Self {
        let largest = vertices
            .iter()
            .flatten()
            .fold(0.0f64, |m, c| m.max(c.abs()));
        let rounding_max = vertices
            .iter()
            .map(|&p| crate::geom::length(crate::geom::sub(layout.stored(p), p)))
            .fold(0.0f64, f64::max);
        FileReport {
            format: layout.format().name(),
            precision: precision.name(),
            coordinates: layout.coords(),
            origin: layout.origin(),
            f32_step: f32_step(largest),
            f32_step_allowed: allowed,
            rounding_max,
            normals,
            colors,
        }
    }

    /// Whether the file holds `float32` coordinates where `auto` would not
    /// have (`--precision f32`, or STL): the run warns.
    pub fn coarser_than_auto(&self) -> bool {
        self.coordinates == Coords::F32 && self.f32_step > self.f32_step_allowed
    }

    /// The `file` line.
    pub fn text(&self) -> String {
        let format = match self.format {
            "ply" => "binary PLY",
            "obj" => "OBJ",
            "off" => "OFF",
            "stl" => "binary STL",
            "glb" => "glTF binary (GLB)",
            other => other,
        };
        let coords = match (self.coordinates, self.origin) {
            (Coords::F32Offset, Some([x, y, z])) => {
                format!("float32 offsets from an origin at ({x}, {y}, {z})")
            }
            (Coords::F64, _) => "float64 coordinates".to_string(),
            _ => "float32 coordinates".to_string(),
        };
        let against = if self.f32_step > self.f32_step_allowed {
            "over"
        } else {
            "within"
        };
        let mut extra = String::new();
        if self.normals {
            extra.push_str("; vertex normals");
        }
        if self.colors {
            extra.push_str("; colours of the input averaged per cluster");
        }
        let moved = if self.rounding_max > 0.0 {
            format!("vertices moved by up to {:.3e}", self.rounding_max)
        } else {
            "no vertex moved".to_string()
        };
        format!(
            "file       {format}, {coords} (float32 steps {:.3e} at the largest coordinate, \
             {against} the {:.3e} allowed; {moved}){extra}\n",
            self.f32_step, self.f32_step_allowed
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_clean_line_and_the_clean_fields_give_the_same_counts() {
        let stats = CleanStats {
            points: 6000,
            kept: 5957,
            outliers: 3,
            fragments: 1,
            fragment_points: 40,
            pieces: 2,
            ..CleanStats::default()
        };
        let params = Params {
            outlier_sigma: 2.0,
            min_fragment: 64,
            ..Params::default()
        };
        let r = CleanReport::new(Some(&stats), &params);
        assert_eq!(
            r.text(5957, 6000),
            "3 outliers removed (over 2 standard deviations), 1 fragment dropped \
             (40 points; pieces under 64 points); 5957 of 6000 points kept in 2 pieces"
        );
        assert_eq!(
            serde_json::to_value(r).unwrap(),
            serde_json::json!({
                "outlier_sigma": 2.0,
                "min_fragment": 64,
                "outliers_removed": 3,
                "fragments_dropped": 1,
                "fragment_points": 40,
                "pieces": 2,
            })
        );
    }

    #[test]
    fn the_input_line_and_fields_give_the_invalid_points_skipped() {
        let params = Params {
            outlier_sigma: 0.0,
            min_fragment: 0,
            ..Params::default()
        };
        let mut r = InputReport {
            input: Source::File {
                path: "scan.pcd".into(),
            },
            points_read: 4000,
            invalid_skipped: 544,
            duplicates_merged: 0,
            points: 4000,
            normals_given: false,
            diagonal: 2.0,
            clean: CleanReport::new(None, &params),
        };
        assert!(
            r.text().starts_with(
                "input      scan.pcd: 4000 points (544 invalid skipped), normals by PCA"
            ),
            "{}",
            r.text()
        );
        let json = serde_json::to_value(&r).unwrap();
        assert_eq!(json["invalid_skipped"], serde_json::json!(544));
        r.invalid_skipped = 0;
        assert!(r
            .text()
            .starts_with("input      scan.pcd: 4000 points, normals"));
    }

    #[test]
    fn the_input_line_and_fields_give_the_duplicates_merged() {
        let params = Params::default();
        let stats = CleanStats {
            points: 400,
            kept: 400,
            pieces: 1,
            ..CleanStats::default()
        };
        let r = InputReport {
            input: Source::File {
                path: "scan.xyz".into(),
            },
            points_read: 4000,
            invalid_skipped: 0,
            duplicates_merged: 3600,
            points: 400,
            normals_given: false,
            diagonal: 2.0,
            clean: CleanReport::new(Some(&stats), &params),
        };
        let text = r.text();
        assert!(
            text.starts_with(
                "input      scan.xyz: 4000 points, 3600 exact duplicates merged (400 distinct), \
                 normals by PCA"
            ),
            "{text}"
        );
        assert!(text.contains("400 of 400 points kept in 1 piece"), "{text}");
        let json = serde_json::to_value(&r).unwrap();
        assert_eq!(json["points_read"], serde_json::json!(4000));
        assert_eq!(json["duplicates_merged"], serde_json::json!(3600));
        assert_eq!(json["points"], serde_json::json!(400));
    }

    #[test]
    fn cleaning_off_reads_off_and_counts_nothing() {
        let params = Params {
            outlier_sigma: 0.0,
            min_fragment: 0,
            ..Params::default()
        };
        let r = CleanReport::new(None, &params);
        assert_eq!(r.text(100, 100), "off");
        let v = serde_json::to_value(r).unwrap();
        assert_eq!(v["outliers_removed"], 0);
        assert_eq!(v["fragments_dropped"], 0);
    }

    #[test]
    fn every_parameter_is_echoed_under_its_core_name() {
        let params = Params {
            k: 7,
            seed: 99,
            max_error: 0.25,
            smooth_rounds: 3,
            ..Params::default()
        };
        let run = RunParams {
            threads: 2,
            memory: None,
        };
        let v = serde_json::to_value(ParamsReport::new(&params, true, run)).unwrap();
        assert_eq!(v["clustering"]["k"], 7);
        assert_eq!(v["clustering"]["seed"], 99);
        assert_eq!(v["meshing"]["max_error"], 0.25);
        assert_eq!(v["cleaning"]["smooth_rounds"], 3);
        assert_eq!(v["run"]["memory"], serde_json::Value::Null);
        assert_eq!(v["clustering"]["partition"], "auto");
        // 27 fields of Params, the meshing memory used, and the run's two.
        let fields: usize = ["cleaning", "clustering", "meshing", "run"]
            .iter()
            .map(|g| v[g].as_object().unwrap().len())
            .sum();
        assert_eq!(fields, 27 + 1 + 2);
        let v = serde_json::to_value(ParamsReport::new(&params, false, run)).unwrap();
        assert!(v.get("meshing").is_none());
    }

    #[test]
    fn the_file_line_and_fields_say_how_the_coordinates_were_stored() {
        use crate::io::MeshFormat;
        let v = [
            [500_000.0, 4_000_000.1, 100.0],
            [500_001.0, 4_000_000.0, 99.0],
        ];
        let allowed = 0.002;
        let layout = |p| MeshLayout::choose(MeshFormat::Ply, p, &v, allowed).unwrap();
        let auto = FileReport::new(
            &layout(Precision::Auto),
            Precision::Auto,
            &v,
            allowed,
            true,
            false,
        );
        assert_eq!(auto.coordinates, Coords::F64);
        assert!(!auto.coarser_than_auto());
        assert!(
            auto.text().starts_with(
                "file       binary PLY, float64 coordinates (float32 steps 2.500e-1 at the \
                 largest coordinate, over the 2.000e-3 allowed; no vertex moved); vertex normals\n"
            ),
            "{}",
            auto.text()
        );
        let f32 = FileReport::new(
            &layout(Precision::F32),
            Precision::F32,
            &v,
            allowed,
            false,
            true,
        );
        assert!(f32.coarser_than_auto());
        assert!(f32.rounding_max > allowed && f32.rounding_max <= 0.125 * 3f64.sqrt());
        assert!(f32
            .text()
            .ends_with("; colours of the input averaged per cluster\n"));
        let json = serde_json::to_value(&f32).unwrap();
        assert_eq!(json["coordinates"], "f32");
        assert_eq!(json["precision"], "f32");
        assert_eq!(json["origin"], serde_json::Value::Null);
    }

    /// The check with its two tasks run last first, on two threads, or not
    /// at all by the runner is the check run one task after another: on two
    /// tetrahedra through each other (crossing faces) and an open one.
    #[test]
    fn the_check_in_tasks_is_the_check_in_turn() {
        let tet = |o: [f64; 3]| {
            [
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ]
            .map(|p| [p[0] + o[0], p[1] + o[1], p[2] + o[2]])
        };
        let v: Vec<[f64; 3]> = [tet([0.0; 3]), tet([0.2, 0.2, 0.2]), tet([5.0, 0.0, 0.0])].concat();
        let faces = |b: u32| [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]].map(|f| f.map(|i| i + b));
        let f: Vec<[u32; 3]> = [&faces(0)[..], &faces(4)[..], &faces(8)[..3]].concat();
        let want = MeshCheck::new(&v, &f);
        assert!(want.validity.self_intersecting_pairs > 0, "{want:?}");
        assert_eq!(want.topology.boundary_edges, 3);
        let backwards = |tasks: &mut [&mut dyn Task]| tasks.iter_mut().rev().for_each(|t| t.run());
        let threads = |tasks: &mut [&mut dyn Task]| {
            std::thread::scope(|s| {
                for t in tasks.iter_mut() {
                    s.spawn(move || t.run());
                }
            })
        };
        let none = |_: &mut [&mut dyn Task]| {};
        for run in [&backwards as &dyn Fn(&mut [&mut dyn Task]), &threads, &none] {
            let got = MeshCheck::new_with(&v, &f, run);
            assert_eq!(format!("{got:?}"), format!("{want:?}"));
        }
    }

    #[test]
    fn a_closed_tetrahedron_checks_as_a_valid_solid_and_an_open_one_does_not() {
        let v = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ];
        let closed = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]];
        let c = MeshCheck::new(&v, &closed);
        assert!(
            c.watertight && c.manifold && c.oriented && c.valid_solid,
            "{c:?}"
        );
        assert_eq!(
            (c.topology.euler, c.validity.genus.as_slice()),
            (2, &[0][..])
        );
        assert!(c
            .text()
            .starts_with("check      valid solid: yes (watertight"));
        let open = MeshCheck::new(&v, &closed[..3]);
        assert!(!open.watertight && open.manifold && !open.valid_solid);
        assert_eq!(open.topology.boundary_edges, 3);
    }
}
