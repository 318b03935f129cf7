//! `vsaqem cluster`: the input points coloured by cluster, plus the generators.

use crate::cmd::{
    arena_buffer, clean_input, clean_json, clean_text, label_colour, with_clean, MemoryArgs,
};
use crate::input::{self, Prepared};
use crate::io::{write_atomic, write_points_ply};
use crate::json;
use crate::progress::StageClock;
use clap::Args;
use std::path::{Path, PathBuf};
use std::time::Instant;
use vsaqem_core::sample::Shape;
use vsaqem_core::{CleanStats, Clustered, Params};

/// Where the points come from.
#[derive(Args, Debug, Clone)]
pub struct InputArgs {
    /// Point cloud to read (.ply, .xyz/.xyzn/.txt/.pts, .pcd; normals used when
    /// present). Without it, a built-in generated sample is used.
    pub input: Option<PathBuf>,
    /// Built-in sample when no input is given: demo, sphere, torus, box, cylinder
    /// (closed); hemisphere, tube, wave, holed-sphere (open surfaces); scene (a
    /// sphere and a cube apart, plus a stray fragment of 40 points).
    #[arg(long, default_value = "demo", value_parser = parse_shape)]
    pub sample: Shape,
    /// Points of the built-in sample.
    #[arg(long, default_value_t = 20_000)]
    pub points: usize,
    /// Gaussian noise added to the built-in sample, as a fraction of its
    /// bounding-box diagonal (e.g. 0.005 = 0.5 %).
    #[arg(long, default_value_t = 0.0)]
    pub noise: f64,
}

fn parse_shape(s: &str) -> Result<Shape, String> {
    Shape::from_name(s).ok_or_else(|| {
        format!(
            "unknown sample '{s}': use demo, sphere, torus, box, cylinder (closed), \
             hemisphere, tube, wave or holed-sphere (open), or scene (two objects and a \
             stray fragment)"
        )
    })
}

/// The cleaning pre-pass (`vsaqem_core::clean`); defaults are
/// `vsaqem_core::Params::default()`.
#[derive(Args, Debug, Clone)]
pub struct CleanArgs {
    /// Remove statistical outliers: points whose mean distance to their --knn
    /// nearest neighbours is more than SIGMA standard deviations above the mean
    /// of all points (e.g. 2 or 3; 0: off).
    #[arg(long = "outliers", value_name = "SIGMA", allow_hyphen_values = true,
          default_value_t = Params::default().outlier_sigma, value_parser = parse_sigma)]
    pub outlier_sigma: f32,
    /// Drop isolated pieces of fewer than N points (pieces: neighbours within
    /// 4 average spacings of each other); the largest piece is always kept
    /// (0: off).
    #[arg(long, value_name = "N", allow_hyphen_values = true,
          default_value_t = Params::default().min_fragment, value_parser = parse_fragment)]
    pub min_fragment: u32,
    /// Rounds of smoothing after cleaning: each moves every point onto the
    /// least-squares plane of its 24 nearest neighbours. For noise near the point
    /// spacing (about 1 % of the diagonal); rounds sharp edges (0: off).
    #[arg(long = "smooth", value_name = "ROUNDS", allow_hyphen_values = true,
          default_value_t = Params::default().smooth_rounds, value_parser = parse_rounds)]
    pub smooth_rounds: u32,
}

fn parse_rounds(s: &str) -> Result<u32, String> {
    s.trim()
        .parse::<u32>()
        .map_err(|_| format!("'{s}' is not a whole number of rounds >= 0 (0: off)"))
}

fn parse_sigma(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!(
            "'{s}' is not a number of standard deviations >= 0 (e.g. 2 or 3; 0: off)"
        )),
    }
}

fn parse_fragment(s: &str) -> Result<u32, String> {
    s.trim()
        .parse::<u32>()
        .map_err(|_| format!("'{s}' is not a whole number of points >= 0 (0: off)"))
}

impl CleanArgs {
    /// `params` with these cleaning settings.
    pub fn apply(&self, params: Params) -> Params {
        Params {
            outlier_sigma: self.outlier_sigma,
            min_fragment: self.min_fragment,
            smooth_rounds: self.smooth_rounds,
            ..params
        }
    }
}

/// Clustering parameters; defaults are `vsaqem_core::Params::default()`.
#[derive(Args, Debug, Clone)]
pub struct ClusterArgs {
    /// Initial number of clusters (generators); the output has about this many
    /// vertices, more where splitting adds some.
    #[arg(long, default_value_t = Params::default().clusters)]
    pub clusters: u32,
    /// Cap on clusters that splitting may reach (0: twice --clusters).
    #[arg(long, default_value_t = Params::default().max_clusters)]
    pub max_clusters: u32,
    /// Partition + generator-update passes before splitting.
    #[arg(long, default_value_t = Params::default().iterations)]
    pub iterations: u32,
    /// Passes after each splitting batch.
    #[arg(long, default_value_t = Params::default().split_iterations)]
    pub split_iterations: u32,
    /// Splitting batches at most (0 disables splitting).
    #[arg(long, default_value_t = Params::default().split_rounds)]
    pub split_rounds: u32,
    /// Largest allowed error of a point against its cluster's generator, as a
    /// fraction of the bounding-box diagonal (0 disables splitting); never below
    /// 4 times the noise floor of the data.
    #[arg(long, default_value_t = Params::default().tolerance)]
    pub tolerance: f32,
    /// Weight of the Euclidean term in the partition cost (dimensionless).
    #[arg(long, default_value_t = Params::default().lambda)]
    pub lambda: f32,
    /// Neighbours per point (1 to 32).
    #[arg(long, default_value_t = Params::default().k)]
    pub knn: usize,
    /// Seed of the generator initialisation (same seed, same output).
    #[arg(long, default_value_t = Params::default().seed)]
    pub seed: u64,
}

impl ClusterArgs {
    /// The core parameters.
    pub fn params(&self) -> Params {
        Params {
            k: self.knn,
            clusters: self.clusters,
            max_clusters: self.max_clusters,
            iterations: self.iterations,
            split_iterations: self.split_iterations,
            split_rounds: self.split_rounds,
            tolerance: self.tolerance,
            lambda: self.lambda,
            seed: self.seed,
            ..Params::default()
        }
    }
}

/// `vsaqem cluster`.
#[derive(Args, Debug)]
pub struct Cmd {
    #[command(flatten)]
    pub input: InputArgs,
    #[command(flatten)]
    pub clean: CleanArgs,
    #[command(flatten)]
    pub cluster: ClusterArgs,
    #[command(flatten)]
    pub memory: MemoryArgs,
    /// Output PLY: input points coloured by cluster (property `cluster`), then the
    /// generators in black.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also write the report as JSON to this file.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// No progress bar.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Read (or sample) and normalise, timing it.
pub fn read_input(args: &InputArgs, clock: &mut StageClock) -> Result<Prepared, String> {
    let t = Instant::now();
    let (name, cloud) = input::load(
        args.input.as_deref(),
        args.sample,
        args.points,
        args.noise,
        1,
    )?;
    let prepared = input::prepare(name, cloud);
    clock.record("read", t.elapsed());
    Ok(prepared)
}

/// Run the command.
pub fn run(cmd: &Cmd) -> Result<(), String> {
    let mut clock = StageClock::new(!cmd.quiet);
    let input = read_input(&cmd.input, &mut clock)?;
    let params = cmd.clean.apply(cmd.cluster.params());
    let read = input.points.len();
    let needed = with_clean(vsaqem_core::cluster_bytes(read, &params), read, &params);
    let bytes = cmd.memory.arena_size(needed, read)?;
    let mut buf = arena_buffer(bytes);
    let (input, clean) =
        clean_input(input, &params, &mut buf, &mut clock).inspect_err(|_| clock.finish())?;
    let arena = vsaqem_core::Arena::new(&mut buf);
    let out = vsaqem_core::cluster(
        &arena,
        &input.points,
        input.normals.as_deref(),
        &params,
        &mut clock,
    );
    clock.finish();
    let out = out.map_err(|e| format!("{}: {e}", input.name))?;
    let t = Instant::now();
    write_clusters(&cmd.output, &input, &out)?;
    clock.record("write", t.elapsed());
    let report = Report {
        input: &input,
        read,
        clean: clean.as_ref(),
        out: &out,
        params: &params,
        clock: &clock,
        arena_bytes: bytes,
        output: &cmd.output,
    };
    crate::cmd::publish(&report.text(), cmd.report.as_deref(), || report.json())?;
    Ok(())
}

fn write_clusters(path: &Path, input: &Prepared, out: &Clustered) -> Result<(), String> {
    let labels = out.clusters.labels;
    let gens = out.clusters.generators;
    let mut pts = input.original.clone();
    pts.extend(gens.iter().map(|&g| input.frame.to_file(g)));
    let mut colours: Vec<[u8; 3]> = labels.iter().map(|&l| label_colour(l)).collect();
    colours.extend(std::iter::repeat_n([0, 0, 0], gens.len()));
    let mut ids = labels.to_vec();
    ids.extend(0..gens.len() as u32);
    write_atomic(path, |w| {
        write_points_ply(w, &pts, &colours, Some(("cluster", &ids)))
    })
    .map_err(|e| e.to_string())
}

struct Report<'r> {
    input: &'r Prepared,
    /// Points read, before cleaning.
    read: usize,
    clean: Option<&'r CleanStats>,
    out: &'r Clustered<'r>,
    params: &'r Params,
    clock: &'r StageClock,
    arena_bytes: usize,
    output: &'r Path,
}

impl Report<'_> {
    fn text(&self) -> String {
        let s = &self.out.stats;
        let c = &s.cluster;
        let n = self.input.points.len();
        let diag = self.out.bounds.diag as f64 * self.input.frame.scale;
        let normals = if self.input.normals.is_some() {
            "normals given"
        } else {
            "normals by PCA"
        };
        format!(
            "input      {}: {} points, {normals}, bounding-box diagonal {diag:.6}\n\
             clean      {}\n\
             neighbours k = {}, average spacing {:.3}% of the diagonal\n\
             clusters   {} ({} initial, +{} by splitting in {} batches, {} batches undone), {} passes{}\n\
             max error  {:.3}% of the diagonal (tolerance {:.3}%)\n\
             time       {}\n\
             memory     arena peak {} bytes ({:.1} bytes/point), {} reserved\n\
             output     {}: {n} points coloured by cluster + {} generators (black)\n",
            self.input.name,
            self.read,
            clean_text(self.clean, self.params),
            s.k,
            s.spacing as f64 / self.out.bounds.diag as f64 * 100.0,
            c.clusters,
            c.initial_clusters,
            c.splits,
            c.split_rounds,
            c.rejected_batches,
            c.passes,
            if c.converged { ", converged" } else { "" },
            c.max_error * 100.0,
            c.tolerance * 100.0,
            self.clock.summary(),
            s.peak_clustering,
            s.peak_clustering as f64 / n as f64,
            self.arena_bytes,
            self.output.display(),
            c.clusters,
        )
    }

    fn json(&self) -> String {
        let s = &self.out.stats;
        let c = &s.cluster;
        let mut o = json::Obj::default();
        o.str("input", &self.input.name)
            .num("points", self.input.points.len() as f64)
            .bool("normals_given", self.input.normals.is_some())
            .num(
                "diagonal",
                self.out.bounds.diag as f64 * self.input.frame.scale,
            );
        clean_json(&mut o, self.clean, self.read, self.params);
        o.num("k", s.k as f64)
            .num(
                "spacing_relative",
                s.spacing as f64 / self.out.bounds.diag as f64,
            )
            .num("components", c.components as f64)
            .num("initial_clusters", c.initial_clusters as f64)
            .num("clusters", c.clusters as f64)
            .num("passes", c.passes as f64)
            .num("split_batches", c.split_rounds as f64)
            .num("split_batches_undone", c.rejected_batches as f64)
            .num("splits", c.splits as f64)
            .bool("converged", c.converged)
            .num("max_error_relative", c.max_error as f64)
            .num("tolerance_relative", self.params.tolerance as f64)
            .num("tolerance_used_relative", c.tolerance as f64)
            .num("noise_floor_relative", c.noise as f64)
            .raw("time_ms", &self.clock.json())
            .num("arena_peak_bytes", s.peak_clustering as f64)
            .num("arena_reserved_bytes", self.arena_bytes as f64)
            .str("output", &self.output.display().to_string());
        o.finish() + "\n"
    }
}
