//! The arguments `cluster` and `reconstruct` share, and what they turn into: the
//! points ([`read_input`]) and the arena buffer ([`arena_buffer`]) of a run.

use crate::input::{self, Prepared};
use crate::io::xyz::Columns;
use crate::io::{is_cloud_extension, Cloud, ReadOptions, CLOUD_EXTENSIONS};
use crate::limits::{at_most, MemoryLimit, MAX_SAMPLE_POINTS};
use crate::progress::StageClock;
use clap::{Args, ValueEnum};
use std::mem::MaybeUninit;
use std::path::PathBuf;
use vsaqem_core::sample::Shape;
use vsaqem_core::{Params, Partition, MAX_K};

/// Where the points come from.
#[derive(Args, Debug, Clone)]
#[command(next_help_heading = "Input")]
pub struct InputArgs {
    /// Point cloud to read: .ply, .xyz/.xyzn/.txt/.pts/.csv (text), .pcd, .las/.laz,
    /// .e57, or a mesh (.obj, .off, .stl; a PLY mesh too) whose vertices are the
    /// points; - reads standard input (its format from --format, or else from
    /// its first bytes). At most 4 GiB; a stream whose first bytes cannot open
    /// its format fails on them. Without it, a built-in generated sample is used.
    pub input: Option<PathBuf>,
    /// Points a library caller gives in memory (the Python module), read
    /// instead of INPUT or a sample: not an option of the command line.
    #[arg(skip)]
    pub given: Option<Given>,
    /// The input's format, as one of INPUT's extensions (e.g. ply, xyz, las),
    /// over the file's extension; for - (standard input) over what its first
    /// bytes say (a header of PLY, PCD, LAS/LAZ, E57, OFF, OBJ or STL, else
    /// text columns).
    #[arg(long, value_name = "EXT", value_parser = parse_format)]
    pub format: Option<String>,
    /// Normals in the file: `use` them where finite and non-zero (core estimates
    /// the others from the neighbours), or `ignore` them all and estimate every
    /// normal (for normals that are noisy, or oriented inconsistently).
    #[arg(long, value_enum, value_name = "MODE", default_value_t = NormalsMode::Use)]
    pub normals: NormalsMode,
    /// What the columns of a text cloud hold, over its header line or the guess
    /// from the column count: names separated by commas from x, y, z, nx, ny, nz,
    /// r, g, b (0-255 or 0-1), and _ for a column to skip (e.g. x,y,z,nx,ny,nz or
    /// x,y,z,_,r,g,b).
    #[arg(long, value_name = "NAMES")]
    pub columns: Option<Columns>,
    /// Built-in sample when no input is given: demo, sphere, torus, box, cylinder
    /// (closed); hemisphere, tube, wave, holed-sphere (open surfaces); scene (a
    /// sphere and a cube apart, plus a stray fragment of 40 points).
    #[arg(long, default_value = "demo", value_parser = parse_shape)]
    pub sample: Shape,
    /// Points of the built-in sample (at most 100,000,000).
    #[arg(long, default_value_t = 20_000)]
    pub points: usize,
    /// Gaussian noise added to the built-in sample, as a fraction of its
    /// bounding-box diagonal (e.g. 0.005 = 0.5 %).
    #[arg(long, default_value_t = 0.0)]
    pub noise: f64,
}

/// What to do with the normals a file gives (`--normals`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum NormalsMode {
    /// Use the file's normals where finite and non-zero.
    Use,
    /// Drop them: core estimates every normal.
    Ignore,
}

impl InputArgs {
    /// `--points` within [`MAX_SAMPLE_POINTS`], checked before any work.
    pub fn check_limits(&self) -> Result<(), String> {
        at_most(
            "--points",
            self.points as u64,
            MAX_SAMPLE_POINTS as u64,
            "points of a built-in sample",
        )
    }

    /// How the input file is to be read.
    pub fn read_options(&self) -> ReadOptions {
        ReadOptions {
            columns: self.columns.clone(),
            format: self.format.clone(),
        }
    }
}

/// `--format`: an extension the cloud readers know, with or without its dot.
fn parse_format(s: &str) -> Result<String, String> {
    let ext = s.trim().trim_start_matches('.').to_ascii_lowercase();
    if is_cloud_extension(&ext) {
        Ok(ext)
    } else {
        Err(format!(
            "'{s}' is not a cloud format: use one of {}",
            CLOUD_EXTENSIONS.replace('.', "")
        ))
    }
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

/// A cloud a library caller gives ([`InputArgs::given`]), taken by the one
/// run that reads it (clones share it: it is read once, never copied).
#[derive(Clone, Debug, Default)]
pub struct Given {
    cloud: std::sync::Arc<std::sync::Mutex<Option<Cloud>>>,
    points: usize,
}

impl Given {
    /// `cloud` as a command's input.
    pub fn new(cloud: Cloud) -> Given {
        Given {
            points: cloud.positions.len(),
            cloud: std::sync::Arc::new(std::sync::Mutex::new(Some(cloud))),
        }
    }

    /// Points given.
    pub fn points(&self) -> usize {
        self.points
    }
}

/// Read (or sample) and normalise, timing it.
pub fn read_input(args: &InputArgs, clock: &mut StageClock) -> Result<Prepared, String> {
    if let Some(given) = &args.given {
        let cloud = given.cloud.lock().ok().and_then(|mut c| c.take());
        let mut cloud = cloud.ok_or("the points given were read by an earlier run")?;
        if args.normals == NormalsMode::Ignore {
            cloud.normals = None;
        }
        return clock.time("read", || input::prepare(input::GIVEN.to_string(), cloud));
    }
    clock.time("read", || {
        let (name, mut cloud) = input::load(
            args.input.as_deref(),
            &args.read_options(),
            args.sample,
            args.points,
            args.noise,
            input::SAMPLE_SEED,
        )?;
        if args.normals == NormalsMode::Ignore {
            cloud.normals = None;
        }
        input::prepare(name, cloud)
    })
}

/// The cleaning pre-pass (`vsaqem_core::clean`); defaults are
/// `vsaqem_core::Params::default()`.
#[derive(Args, Debug, Clone)]
#[command(next_help_heading = "Cleaning")]
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
#[command(next_help_heading = "Clustering")]
pub struct ClusterArgs {
    /// Initial number of clusters (generators); the output has about this many
    /// vertices, more where splitting adds some (reconstruct: at least 4).
    #[arg(long, default_value_t = Params::default().clusters)]
    pub clusters: u32,
    /// Cap on clusters that splitting may reach (0: twice --clusters);
    /// refinement may go a thirty-second past it for clusters the mesh leaves
    /// out and at the rims of gaps.
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
    #[arg(long, value_name = "K", default_value_t = Params::default().k, value_parser = parse_knn)]
    pub knn: usize,
    /// Seed of the generator initialisation (same seed, same output).
    #[arg(long, default_value_t = Params::default().seed)]
    pub seed: u64,
    /// How each pass partitions the points: `grow` (region growing, one
    /// thread), `sweep` (synchronous sweeps on every thread, each pass from
    /// the last one's clusters; other clusters than `grow`'s), `auto` (sweep
    /// from 131,072 points on).
    #[arg(long, value_enum, default_value_t = PartitionArg::Auto)]
    pub partition: PartitionArg,
}

/// `--partition`: [`Partition`] on the command line.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum PartitionArg {
    /// Sweep from 131,072 points on, grow below.
    Auto,
    /// Region growing.
    Grow,
    /// Synchronous sweeps.
    Sweep,
}

impl From<PartitionArg> for Partition {
    fn from(p: PartitionArg) -> Self {
        match p {
            PartitionArg::Auto => Partition::Auto,
            PartitionArg::Grow => Partition::Grow,
            PartitionArg::Sweep => Partition::Sweep,
        }
    }
}

/// `--knn`: 1 to [`MAX_K`], the most core's neighbour search holds.
fn parse_knn(s: &str) -> Result<usize, String> {
    match s.trim().parse::<usize>() {
        Ok(k) if (1..=MAX_K).contains(&k) => Ok(k),
        Ok(k) if k > MAX_K => Err(format!(
            "{k} neighbours is more than the limit of {MAX_K} (--knn takes 1 to {MAX_K})"
        )),
        _ => Err(format!(
            "'{s}' is not a number of neighbours from 1 to {MAX_K}"
        )),
    }
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
            partition: self.partition.into(),
            ..Params::default()
        }
    }
}

/// The arena budget of a run.
#[derive(Args, Debug, Clone)]
#[command(next_help_heading = "Run")]
pub struct MemoryArgs {
    /// Arena size in bytes (suffixes KiB, MiB, GiB; e.g. 64MiB, 1.5GiB, 200000),
    /// at most the machine's physical memory (1 TiB where it is not known).
    /// Default: the most this run can need, as core bounds it for these points
    /// and parameters, up to that limit. Less than the run needs fails at once,
    /// naming the size needed; more is allowed but never used.
    #[arg(long, value_name = "BYTES", value_parser = parse_bytes)]
    pub memory: Option<usize>,
    /// Threads to run on (default: every core). The output is the same for
    /// every count. On Linux, when N is at most the CPUs the process may use,
    /// each helper thread runs its first round on a CPU other than the
    /// calling thread's.
    #[arg(long, value_name = "N", allow_hyphen_values = true, value_parser = parse_threads)]
    pub threads: Option<usize>,
}

fn parse_threads(s: &str) -> Result<usize, String> {
    match s.parse::<usize>() {
        Ok(n) if (1..=MAX_THREADS).contains(&n) => Ok(n),
        _ => Err(format!(
            "'{s}' is not a thread count from 1 to {MAX_THREADS}"
        )),
    }
}

/// The most threads `--threads` takes: each parallel stage is cut into
/// `vsaqem_core::parallel::TASKS` tasks, so more could never be busy.
const MAX_THREADS: usize = vsaqem_core::parallel::TASKS;

impl MemoryArgs {
    /// `--threads`, or every core the system offers.
    pub fn threads(&self) -> usize {
        self.threads.unwrap_or_else(|| {
            std::thread::available_parallelism().map_or(1, |n| n.get().min(MAX_THREADS))
        })
    }

    /// The arena size to use when the run needs `needed` bytes at most and at
    /// least `least` (what any cloud of `points` points needs; what this one
    /// needs depends on its neighbour graph, which core checks as soon as it is
    /// counted): the `--memory` budget, checked against `least` and the
    /// machine's [`MemoryLimit`] before any work, or `needed` up to that limit.
    pub fn arena_size(&self, needed: usize, least: usize, points: usize) -> Result<usize, String> {
        let limit = MemoryLimit::of_machine();
        let too_small = |given: usize, flag: &str| {
            format!(
                "{flag} {given} bytes ({:.1} MiB) is too small: this run needs at least \
                 {least} bytes ({:.1} MiB) for {points} points with these parameters (up to \
                 {needed}, {:.1} MiB, depending on the cloud); give more, or use fewer \
                 clusters or neighbours",
                mib(given),
                mib(least),
                mib(needed)
            )
        };
        match self.memory {
            Some(given) if given > limit.bytes => Err(format!(
                "--memory {given} bytes ({:.1} MiB) is more than {limit}",
                mib(given)
            )),
            Some(given) if given >= least => Ok(given),
            Some(given) => Err(too_small(given, "--memory")),
            None if least > limit.bytes => Err(format!(
                "this run needs at least {least} bytes ({:.1} MiB) for {points} points with \
                 these parameters, more than {limit}; use fewer points, clusters or neighbours",
                mib(least)
            )),
            None => Ok(needed.min(limit.bytes)),
        }
    }
}

fn mib(bytes: usize) -> f64 {
    bytes as f64 / (1u64 << 20) as f64
}

/// A byte count: a whole number of bytes, or a number with a unit: `KiB`, `MiB`,
/// `GiB` (also `K`, `M`, `G`), `KB`, `MB`, `GB` (powers of 1000) or `B`, any
/// case, e.g. `64MiB`, `1.5GiB`, `200000`. Fractions of a byte are dropped.
pub fn parse_bytes(s: &str) -> Result<usize, String> {
    let t = s.trim();
    let at = t.find(|c: char| c.is_ascii_alphabetic()).unwrap_or(t.len());
    let (number, unit) = (t[..at].trim(), t[at..].trim());
    let scale: u64 = match unit.to_ascii_lowercase().as_str() {
        "" | "b" => 1,
        "k" | "kib" => 1 << 10,
        "m" | "mib" => 1 << 20,
        "g" | "gib" => 1 << 30,
        "kb" => 1_000,
        "mb" => 1_000_000,
        "gb" => 1_000_000_000,
        _ => {
            return Err(format!(
                "'{s}': unknown unit '{unit}' (use bytes, KiB, MiB or GiB, e.g. 64MiB)"
            ))
        }
    };
    let too_large = || format!("'{s}': too large for this machine");
    if !number.is_empty() && number.bytes().all(|b| b.is_ascii_digit()) {
        let whole: u64 = number.parse().map_err(|_| too_large())?;
        let bytes = whole.checked_mul(scale).ok_or_else(too_large)?;
        return usize::try_from(bytes).map_err(|_| too_large());
    }
    let value: f64 = number
        .parse()
        .ok()
        .filter(|v: &f64| v.is_finite() && *v >= 0.0 && !number.starts_with(['+', '-']))
        .ok_or_else(|| format!("'{s}': not a size (a number of bytes, or e.g. 64MiB)"))?;
    if scale == 1 && value.fract() != 0.0 {
        return Err(format!("'{s}': not a whole number of bytes"));
    }
    let bytes = (value * scale as f64).floor();
    if bytes >= usize::MAX as f64 || bytes >= (1u64 << 53) as f64 {
        return Err(too_large());
    }
    Ok(bytes as usize)
}

/// A buffer of `bytes` uninitialised bytes for the core arena, or an error
/// naming the size when the system will not reserve it. The pages are not
/// touched until core uses them, so the process's resident memory follows the
/// arena's real use, not its size.
pub fn arena_buffer(bytes: usize) -> Result<Vec<MaybeUninit<u8>>, String> {
    let mut v = Vec::new();
    v.try_reserve_exact(bytes).map_err(|e| {
        format!(
            "cannot reserve an arena of {bytes} bytes ({:.1} MiB): {e}; give less --memory",
            mib(bytes)
        )
    })?;
    // Nothing is written: the bytes stay uninitialised, their pages untouched.
    v.resize(bytes, MaybeUninit::uninit());
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::parse_bytes;

    #[test]
    fn sizes_parse_with_and_without_units() {
        assert_eq!(parse_bytes("200000"), Ok(200_000));
        assert_eq!(parse_bytes("64MiB"), Ok(64 << 20));
        assert_eq!(parse_bytes("1.5GiB"), Ok(3 << 29));
        assert_eq!(parse_bytes("512 KiB"), Ok(512 << 10));
        assert_eq!(parse_bytes("2k"), Ok(2048));
        assert_eq!(parse_bytes("3MB"), Ok(3_000_000));
        assert_eq!(parse_bytes("100b"), Ok(100));
        assert_eq!(parse_bytes("0.5KiB"), Ok(512));
        assert_eq!(parse_bytes("1.0001KiB"), Ok(1024));
        for bad in [
            "",
            "MiB",
            "-5",
            "+5",
            "1.5",
            "12 parsecs",
            "1e400GiB",
            "nan",
            "0x10",
        ] {
            let e = parse_bytes(bad).unwrap_err();
            assert!(e.contains(&format!("'{bad}'")), "{bad}: {e}");
        }
        assert!(parse_bytes("99999999999999999999999").is_err());
        assert!(parse_bytes("99999999999GiB").is_err());
    }
}
