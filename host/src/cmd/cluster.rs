//! `vsaqem cluster`: the input points coloured by cluster, plus the generators.

use crate::args::{CleanArgs, ClusterArgs, InputArgs, MemoryArgs};
use crate::clean::{read_and_clean, Cleaned, RunBytes};
use crate::io::{stage_to, write_points_ply, Staged};
use crate::outputs::check_outputs;
use crate::progress::StageClock;
use crate::report::{
    publish, report_json, ClusteringReport, Header, InputReport, ParamsReport, RunParams,
    RunReport, StagePeaks,
};
use crate::stdout;
use clap::Args;
use serde::Serialize;
use std::path::{Path, PathBuf};
use vsaqem_core::Params;

/// `vsaqem cluster`.
#[derive(Args, Debug)]
pub struct Cmd {
    #[command(flatten)]
    pub input: InputArgs,
    #[command(flatten)]
    pub clean: CleanArgs,
    #[command(flatten)]
    pub cluster: ClusterArgs,
    /// Output PLY: input points coloured by cluster (property `cluster`), then the
    /// generators in black; - writes it to standard output and the report's
    /// text to standard error. Not the input; its directory must exist and be
    /// writable, checked before any work.
    #[arg(short, long, help_heading = "Output")]
    pub output: PathBuf,
    /// Also write the report as JSON to this file (not the input nor the
    /// output; layout: host/report.schema.json); - writes it to standard
    /// output and the text to standard error.
    #[arg(long, value_name = "JSON", help_heading = "Output")]
    pub report: Option<PathBuf>,
    #[command(flatten)]
    pub memory: MemoryArgs,
    /// No progress bar.
    #[arg(short, long, help_heading = "Run")]
    pub quiet: bool,
}

/// The clusters of a command's input, before anything is written: what
/// [`run`] writes and [`cluster`] hands to a library caller.
struct Made {
    /// The input's name, for messages.
    name: String,
    params: Params,
    /// The points clustered (after cleaning and merging duplicates), in the
    /// order they were read, in file coordinates.
    points: Vec<[f64; 3]>,
    /// The cluster of each point.
    labels: Vec<u32>,
    /// The generators, in file coordinates.
    generators: Vec<[f64; 3]>,
    /// The report but for its `run` part.
    report: ClusterReport,
    peaks: StagePeaks,
    arena_reserved: usize,
    arena_needed: usize,
}

/// Read and clean `cmd`'s input and cluster it.
fn make(cmd: &Cmd, clock: &mut StageClock) -> Result<Made, String> {
    let params = cmd.clean.apply(cmd.cluster.params());
    let bytes = RunBytes {
        most: vsaqem_core::cluster_bytes,
        least: vsaqem_core::cluster_bytes_for,
    };
    let Cleaned {
        input,
        points_read,
        stats,
        mut buf,
        rows,
    } = read_and_clean(&cmd.input, &cmd.memory, &params, bytes, clock)?;
    let arena_reserved = buf.len();
    let searched = rows.is_none();
    let arena = vsaqem_core::Arena::new(&mut buf);
    let out = input
        .run_core(
            vsaqem_core::cluster_with_rows,
            rows.as_ref().map(|r| r.rows()).as_ref(),
            &arena,
            &params,
            clock,
        )
        .map_err(|e| match e {
            vsaqem_core::Error::ArenaTooSmall { .. } => format!("{}: {e} (--memory)", input.name),
            e => format!("{}: {e}", input.name),
        })?;
    // The points in the order they were read (core saw them in spatial
    // order, see `Prepared::in_spatial_order`).
    let mut at: Vec<usize> = (0..input.original.len()).collect();
    if let Some(order) = &input.order {
        at.sort_unstable_by_key(|&i| order[i]);
    }
    let diag = out.bounds.diag;
    let report = ClusterReport {
        header: Header::new("cluster"),
        input: InputReport::new(
            &cmd.input,
            &input,
            points_read,
            stats.as_ref(),
            &params,
            diag as f64 * input.frame.scale,
        ),
        params: ParamsReport::new(&params, false, RunParams::of(&cmd.memory)),
        k: out.stats.k,
        spacing_relative: out.stats.spacing as f64 / diag as f64,
        components: out.stats.cluster.components,
        clustering: ClusteringReport::new(&out.stats.cluster, &params, input.points.len()),
        run: None,
    };
    Ok(Made {
        name: input.name.clone(),
        params,
        points: at.iter().map(|&i| input.original[i]).collect(),
        labels: at.iter().map(|&i| out.clusters.labels[i]).collect(),
        generators: out
            .clusters
            .generators
            .iter()
            .map(|&g| input.frame.to_file(g))
            .collect(),
        report,
        peaks: StagePeaks {
            cleaning: stats.map(|s| s.peak),
            neighbours: out.stats.peak_neighbours,
            quadrics: out.stats.peak_quadrics,
            clustering: out.stats.peak_clustering,
            meshing: None,
        },
        arena_reserved,
        arena_needed: bytes.needed(
            &input,
            points_read,
            &params,
            out.stats.reverse_edges as usize,
            searched,
        ),
    })
}

impl Made {
    /// The report, its `run` part read off `clock` now, for `output`.
    fn report(&mut self, clock: &StageClock, output: &Path) -> &ClusterReport {
        self.report.run = Some(RunReport::new(
            clock,
            self.peaks,
            self.arena_reserved,
            self.arena_needed,
            output,
        ));
        &self.report
    }

    /// What the run warns about (without `warning: `).
    fn warnings(&self) -> Vec<String> {
        let c = &self.report.clustering;
        match c.tolerance_unmet(self.params.split_rounds) {
            Some((why, true)) => vec![format!(
                "{}: {why}; largest error {:.3}% of the diagonal",
                self.name,
                c.max_error_relative * 100.0
            )],
            _ => Vec::new(),
        }
    }
}

/// Run the command.
pub fn run(cmd: &Cmd) -> Result<(), String> {
    check_outputs(
        cmd.input.input.as_deref(),
        &cmd.output,
        cmd.report.as_deref(),
    )?;
    let mut clock = StageClock::new(!cmd.quiet).with_threads(cmd.memory.threads());
    let mut made = make(cmd, &mut clock)?;
    let staged = clock.time("write", || write_clusters(&cmd.output, &made))?;
    for warning in made.warnings() {
        stdout::warn(format_args!("warning: {warning}"));
    }
    let report = made.report(&clock, &cmd.output);
    publish(
        &report.text(),
        &cmd.output,
        staged,
        cmd.report.as_deref(),
        || report_json(report),
    )
}

/// Clusters made for a library caller (the Python module).
pub struct Clusters {
    /// The points clustered (after cleaning and merging duplicates), in the
    /// order given.
    pub points: Vec<[f64; 3]>,
    /// The cluster of each point.
    pub labels: Vec<u32>,
    /// The generators, in the points' coordinates.
    pub generators: Vec<[f64; 3]>,
    /// The report as `--report` writes it.
    pub report_json: String,
    /// What the CLI would print as warnings, without `warning: `.
    pub warnings: Vec<String>,
}

/// What [`run`] makes of `cmd`, handed back instead of written.
pub fn cluster(cmd: &Cmd) -> Result<Clusters, String> {
    let mut clock = StageClock::new(false).with_threads(cmd.memory.threads());
    let mut made = make(cmd, &mut clock)?;
    let warnings = made.warnings();
    let report_json = report_json(made.report(&clock, Path::new("")))?;
    Ok(Clusters {
        points: made.points,
        labels: made.labels,
        generators: made.generators,
        report_json,
        warnings,
    })
}

/// The clustered points coloured by cluster, then the generators in black,
/// each with its cluster's id, staged for `path`.
fn write_clusters(path: &Path, made: &Made) -> Result<Staged, String> {
    let gens = &made.generators;
    let mut pts = made.points.clone();
    pts.extend(gens);
    let mut ids = made.labels.clone();
    let mut colours: Vec<[u8; 3]> = ids.iter().map(|&l| label_colour(l)).collect();
    colours.extend(std::iter::repeat_n([0, 0, 0], gens.len()));
    ids.extend(0..gens.len() as u32);
    stage_to(path, |w| {
        write_points_ply(w, &pts, &colours, Some(("cluster", &ids)))
    })
}

/// A bright, deterministic colour for cluster `label`.
fn label_colour(label: u32) -> [u8; 3] {
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

/// The report of a run, filled once from its results: its JSON is this struct
/// serialised, its text reads only this.
#[derive(Serialize)]
struct ClusterReport {
    #[serde(flatten)]
    header: Header,
    #[serde(flatten)]
    input: InputReport,
    params: ParamsReport,
    /// Neighbours per point.
    k: u32,
    /// Average spacing (mean distance to the `k` nearest), relative to the diagonal.
    spacing_relative: f64,
    /// Connected components of the symmetrised neighbour graph.
    components: u32,
    #[serde(flatten)]
    clustering: ClusteringReport,
    /// Filled once the run is over.
    #[serde(flatten)]
    run: Option<RunReport>,
}

impl ClusterReport {
    fn text(&self) -> String {
        let c = &self.clustering;
        let output = format!(
            ": {} points coloured by cluster + {} generators (black)",
            self.input.points, c.clusters
        );
        format!(
            "{}\
             neighbours k = {}, average spacing {:.3}% of the diagonal\n\
             clusters   {} ({} initial, +{} by splitting in {} batches, {} batches undone), {} passes{}\n\
             max error  {:.3}% of the diagonal (tolerance {:.3}%){}\n\
             {}",
            self.input.text(),
            self.k,
            self.spacing_relative * 100.0,
            c.clusters,
            c.initial_clusters,
            c.splits,
            c.split_batches,
            c.split_batches_undone,
            c.passes,
            if c.converged { ", converged" } else { "" },
            c.max_error_relative * 100.0,
            c.tolerance_used_relative * 100.0,
            c.unmet_note(self.params.clustering.split_rounds),
            self.run
                .as_ref()
                .map(|r| r.text(self.input.points, &output))
                .unwrap_or_default(),
        )
    }
}
