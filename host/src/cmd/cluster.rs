//! `vsaqem cluster`: the input points coloured by cluster, plus the generators.

use crate::args::{arena_buffer, read_input, CleanArgs, ClusterArgs, InputArgs, MemoryArgs};
use crate::clean::{clean_input, with_clean};
use crate::cmd::{clean_json, clean_text};
use crate::input::Prepared;
use crate::io::{publish, write_atomic, write_points_ply};
use crate::json;
use crate::progress::StageClock;
use clap::Args;
use std::path::{Path, PathBuf};
use std::time::Instant;
use vsaqem_core::{CleanStats, Clustered, Params};

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
    publish(&report.text(), cmd.report.as_deref(), || report.json()).map_err(|e| e.to_string())?;
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
            self.clock.timings().summary(),
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
            .raw("time_ms", &self.clock.timings().json())
            .num("arena_peak_bytes", s.peak_clustering as f64)
            .num("arena_reserved_bytes", self.arena_bytes as f64)
            .str("output", &self.output.display().to_string());
        o.finish() + "\n"
    }
}
