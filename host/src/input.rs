//! Where the points come from: a file, or a built-in generated sample.

use crate::io::{is_stdio, read_cloud_with, Cloud, ReadOptions};
use crate::normalize::Frame;
use crate::progress::StageClock;
use serde::Serialize;
use std::fmt;
use std::path::Path;
use vsaqem_core::rng::Rng;
use vsaqem_core::sample::{fill, gaussian, Shape};
use vsaqem_core::{Arena, Params, Progress, Rows, V3};

/// A core entry point (`vsaqem_core::cluster_with_rows`,
/// `vsaqem_core::reconstruct_with_rows`) whose results borrow an arena of
/// lifetime `'a`.
pub type CoreRun<'a, 'buf, T> = fn(
    &'a Arena<'buf>,
    &[V3],
    Option<&[V3]>,
    Option<&Rows<'a>>,
    &Params,
    &mut dyn Progress,
) -> vsaqem_core::Result<T>;

/// Points ready for core, with the frame that maps results back.
pub struct Prepared {
    /// What the points are (a file name or the sample's description).
    pub name: String,
    /// Points in core coordinates (`[-1, 1]^3`).
    pub points: Vec<[f32; 3]>,
    /// Normals as given (directions are unchanged by a uniform scale).
    pub normals: Option<Vec<[f32; 3]>>,
    /// Colours as read, when the file has them.
    pub colors: Option<Vec<[u8; 3]>>,
    /// Points the reader skipped as invalid ([`Cloud::invalid`]).
    pub invalid: usize,
    /// Points read at the position of an earlier point, bit for bit, and
    /// merged into it ([`merge_duplicates`]): not among `points`.
    pub duplicates: usize,
    /// Core coordinates <-> file coordinates.
    pub frame: Frame,
    /// Positions as read, in file coordinates.
    pub original: Vec<[f64; 3]>,
    /// The position in the input of each point, when the points were put in
    /// spatial order ([`Prepared::in_spatial_order`]); `None`: input order.
    pub order: Option<Vec<u32>>,
}

/// A built-in sample: `points` points on `shape`, Gaussian noise of standard
/// deviation `noise` times the bounding-box diagonal.
pub fn sample(shape: Shape, points: usize, noise: f64, seed: u64) -> Cloud {
    let mut p = vec![[0.0f32; 3]; points];
    fill(shape, seed, 0.0, &mut p);
    let mut positions: Vec<[f64; 3]> = p.iter().map(|q| q.map(|v| v as f64)).collect();
    if noise > 0.0 {
        let diag = {
            let mut lo = [f64::INFINITY; 3];
            let mut hi = [f64::NEG_INFINITY; 3];
            for q in &positions {
                for a in 0..3 {
                    lo[a] = lo[a].min(q[a]);
                    hi[a] = hi[a].max(q[a]);
                }
            }
            (0..3).map(|a| (hi[a] - lo[a]).powi(2)).sum::<f64>().sqrt()
        };
        let mut rng = Rng::new(seed ^ 0x05EE_D0F0_015E);
        for q in positions.iter_mut() {
            for v in q.iter_mut() {
                *v += noise * diag * gaussian(&mut rng);
            }
        }
    }
    Cloud {
        positions,
        ..Cloud::default()
    }
}

/// Read `path` with `options`, or make the sample when there is no path.
pub fn load(
    path: Option<&Path>,
    options: &ReadOptions,
    shape: Shape,
    points: usize,
    noise: f64,
    seed: u64,
) -> Result<(String, Cloud), String> {
    match path {
        Some(p) => {
            let cloud = read_cloud_with(p, options).map_err(|e| e.to_string())?;
            let name = if is_stdio(p) {
                "standard input".to_string()
            } else {
                p.display().to_string()
            };
            Ok((name, cloud))
        }
        None => {
            let name = Source::of(None, shape, points, noise, seed).to_string();
            Ok((name, sample(shape, points, noise, seed)))
        }
    }
}

/// The name errors and reports give points a library caller gave.
pub const GIVEN: &str = "points";

/// The seed of the built-in samples' points and noise.
pub const SAMPLE_SEED: u64 = 1;

/// Where the points of a run come from, as the report names them: a file, or
/// a built-in sample with what makes it. `Display` is the name errors and the
/// text report use (the path, or `built-in sample 'demo' (20000 points)`).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Source {
    /// A file, as named on the command line (`-`: standard input).
    File {
        /// The path as given.
        path: String,
    },
    /// Points a library caller gave in memory (the Python module's array).
    Array {
        /// Points given.
        points: usize,
    },
    /// A built-in generated sample ([`sample`]).
    Sample {
        /// The shape's name ([`shape_name`]).
        name: &'static str,
        /// Points generated.
        points: usize,
        /// Gaussian noise, fraction of the bounding-box diagonal.
        noise: f64,
        /// Seed of the points and the noise.
        seed: u64,
    },
}

impl Source {
    /// The source [`load`] reads: `path`, or the sample it makes without one.
    pub fn of(path: Option<&Path>, shape: Shape, points: usize, noise: f64, seed: u64) -> Source {
        match path {
            Some(p) => Source::File {
                path: p.display().to_string(),
            },
            None => Source::Sample {
                name: shape_name(shape),
                points,
                noise,
                seed,
            },
        }
    }
}

impl fmt::Display for Source {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Source::File { path } if path == crate::io::STDIO => f.write_str("standard input"),
            Source::File { path } => f.write_str(path),
            Source::Array { .. } => f.write_str(GIVEN),
            Source::Sample {
                name,
                points,
                noise,
                ..
            } if *noise > 0.0 => write!(
                f,
                "built-in sample '{name}' ({points} points, noise {}% of the diagonal)",
                noise * 100.0
            ),
            Source::Sample { name, points, .. } => {
                write!(f, "built-in sample '{name}' ({points} points)")
            }
        }
    }
}

/// The lower-case name of a shape.
pub fn shape_name(s: Shape) -> &'static str {
    match s {
        Shape::Sphere => "sphere",
        Shape::Torus => "torus",
        Shape::Box => "box",
        Shape::Cylinder => "cylinder",
        Shape::Hemisphere => "hemisphere",
        Shape::Tube => "tube",
        Shape::Wave => "wave",
        Shape::HoledSphere => "holed-sphere",
        Shape::Scene => "scene",
        _ => "demo",
    }
}

impl Prepared {
    /// Run `core` on these points (and normals) in `arena`, its stages timed by
    /// `clock`, then close the clock's last stage ([`StageClock::finish`]).
    pub fn run_core<'a, 'buf, T>(
        &self,
        core: CoreRun<'a, 'buf, T>,
        rows: Option<&Rows<'a>>,
        arena: &'a Arena<'buf>,
        params: &Params,
        clock: &mut StageClock,
    ) -> vsaqem_core::Result<T> {
        let out = core(
            arena,
            &self.points,
            self.normals.as_deref(),
            rows,
            params,
            clock,
        );
        clock.finish();
        out
    }

    /// Only the points with `keep[i]` (and their normals and colours), normalised again: the
    /// frame is fitted to what is left, so core's coordinates span `[-1, 1]` for
    /// the cleaned cloud, as they would had it been read that way.
    pub fn keep(self, keep: &[bool]) -> Prepared {
        let kept = |i: &usize| keep.get(*i).copied().unwrap_or(true);
        let original: Vec<[f64; 3]> = (0..self.original.len())
            .filter(kept)
            .map(|i| self.original[i])
            .collect();
        let normals = self
            .normals
            .map(|n| (0..n.len()).filter(kept).map(|i| n[i]).collect());
        let colors = self
            .colors
            .map(|c| (0..c.len()).filter(kept).map(|i| c[i]).collect());
        let order = self
            .order
            .map(|o| (0..o.len()).filter(kept).map(|i| o[i]).collect());
        let frame = Frame::fit(&original);
        Prepared {
            name: self.name,
            points: original.iter().map(|&p| frame.to_core(p)).collect(),
            normals,
            colors,
            invalid: self.invalid,
            duplicates: self.duplicates,
            frame,
            original,
            order,
        }
    }

    /// Clouds of at least [`SPATIAL_ORDER_FROM`] points, with their normals,
    /// colours and positions as read, in the order of a Morton curve over a 1024^3 grid of
    /// the bounding cube, ties by input position: points near in space come
    /// near in memory, so the neighbour search, the partition and the distance
    /// pass find what they read in the processor's caches. On a million points
    /// in random order this takes the whole run from 19.8 s to 12.3 s
    /// (`bench/notes.md`). The order is a function of the points alone, so the
    /// output stays deterministic; smaller clouds keep their order.
    pub fn in_spatial_order(mut self) -> Prepared {
        let n = self.points.len();
        if n < SPATIAL_ORDER_FROM || u32::try_from(n).is_err() {
            return self;
        }
        // Core coordinates lie in [-1, 1]: 10 bits an axis.
        let cell = |v: f32| (((v + 1.0) * 512.0).clamp(0.0, 1023.0)) as u64;
        let mut keys: Vec<u64> = self
            .points
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let code = spread(cell(p[0])) | spread(cell(p[1])) << 1 | spread(cell(p[2])) << 2;
                code << 32 | i as u64
            })
            .collect();
        keys.sort_unstable();
        let order: Vec<u32> = keys.iter().map(|&k| k as u32).collect();
        drop(keys);
        let mut points = Held(&mut self.points[..], None);
        let mut original = Held(&mut self.original[..], None);
        let mut arrays: Vec<&mut dyn Slots> = vec![&mut points, &mut original];
        let mut normals = self.normals.as_deref_mut().map(|n| Held(n, None));
        let mut colors = self.colors.as_deref_mut().map(|c| Held(c, None));
        if let Some(n) = normals.as_mut() {
            arrays.push(n);
        }
        if let Some(c) = colors.as_mut() {
            arrays.push(c);
        }
        permute(&mut arrays, &order);
        self.order = Some(order);
        self
    }
}

/// `v[i] = v[order[i]]` for every `i` at once, for every array `v` of
/// `arrays` (all of one length), in place (cycle by cycle, one bit of scratch a
/// slot), so a large cloud is never held twice. `order` is a permutation of
/// `0..len`. The cycles are walked once for all the arrays: each step reads
/// `order` where the step before pointed, a load that waits for the last one,
/// so walking them once an array took several times as long (a million points
/// in random order: `bench/notes.md`).
fn permute(arrays: &mut [&mut dyn Slots], order: &[u32]) {
    let len = order.len();
    let mut done = vec![0u64; len.div_ceil(64)];
    for start in 0..len {
        if done[start / 64] >> (start % 64) & 1 != 0 {
            continue;
        }
        arrays.iter_mut().for_each(|a| a.hold(start));
        let mut i = start;
        loop {
            done[i / 64] |= 1 << (i % 64);
            let from = order[i] as usize;
            if from == start {
                arrays.iter_mut().for_each(|a| a.put(i));
                break;
            }
            arrays.iter_mut().for_each(|a| a.copy(i, from));
            i = from;
        }
    }
}

/// An array [`permute`] moves the elements of.
trait Slots {
    /// Keep element `i` aside.
    fn hold(&mut self, i: usize);
    /// Element `from` into slot `to`.
    fn copy(&mut self, to: usize, from: usize);
    /// The element kept aside into slot `i`.
    fn put(&mut self, i: usize);
}

/// A slice and the element [`Slots::hold`] kept aside.
struct Held<'a, T>(&'a mut [T], Option<T>);

impl<T: Copy> Slots for Held<'_, T> {
    fn hold(&mut self, i: usize) {
        self.1 = Some(self.0[i]);
    }

    fn copy(&mut self, to: usize, from: usize) {
        self.0[to] = self.0[from];
    }

    fn put(&mut self, i: usize) {
        if let Some(v) = self.1.take() {
            self.0[i] = v;
        }
    }
}

/// Clouds of fewer points keep the order they were read in. Below this their
/// working set (about 150 bytes a point) fits this machine's caches and the
/// order does not change the time (100k random points: the same to 4 %);
/// and the point order picks the initial generators, so reordering the
/// smaller clouds would change meshes whose fidelity `bench/results` records
/// (on the 40 shared-cloud meshes it moved two of them out of the true genus
/// and the scan at 250 clusters to 2 % of its points beyond 1 % of the
/// diagonal: the seed's luck, not the order's merit).
pub const SPATIAL_ORDER_FROM: usize = 1 << 17;

/// The 10 low bits of `v`, two zero bits after each (a Morton code's axis).
fn spread(v: u64) -> u64 {
    let mut v = v & 0x3FF;
    v = (v | v << 16) & 0x0300_00FF;
    v = (v | v << 8) & 0x0300_F00F;
    v = (v | v << 4) & 0x030C_30C3;
    (v | v << 2) & 0x0924_9249
}

/// Merge exact duplicates ([`merge_duplicates`]), then normalise into core
/// coordinates.
pub fn prepare(name: String, mut cloud: Cloud) -> Result<Prepared, String> {
    let duplicates = merge_duplicates(&mut cloud).map_err(|e| format!("{name}: {e}"))?;
    let frame = Frame::fit(&cloud.positions);
    let points = cloud.positions.iter().map(|&p| frame.to_core(p)).collect();
    let normals = cloud
        .normals
        .map(|n| n.iter().map(|v| v.map(|c| c as f32)).collect());
    Ok(Prepared {
        name,
        points,
        normals,
        colors: cloud.colors,
        invalid: cloud.invalid,
        duplicates,
        frame,
        original: cloud.positions,
        order: None,
    }
    .in_spatial_order())
}

/// Keep only the first point read at each position, bit for bit (`-0` and `0`
/// taken as equal), with its normal and colour: the copies after it are
/// dropped, whatever their normals and colours, and the kept points stay in
/// the order read. So a cloud with every point stored several times is the
/// cloud stored once, and gives the same mesh. Returns how many were dropped.
/// `O(n log n)` ([`vsaqem_core::mark_duplicates_hashed`]), 9 bytes a point of
/// scratch.
pub fn merge_duplicates(cloud: &mut Cloud) -> Result<usize, vsaqem_core::Error> {
    use vsaqem_core::prepass::duplicates::{f64_bits, f64_bits_hash};
    let n = cloud.positions.len();
    let mut first = vec![false; n];
    let copies = {
        let mut order = vec![0u64; n];
        let (points, hash) = (&cloud.positions, f64_bits_hash);
        vsaqem_core::mark_duplicates_hashed(points, f64_bits, hash, &mut order, &mut first)?
    };
    if copies > 0 {
        retain(&mut cloud.positions, &first);
        if let Some(normals) = cloud.normals.as_mut() {
            retain(normals, &first);
        }
        if let Some(colors) = cloud.colors.as_mut() {
            retain(colors, &first);
        }
    }
    Ok(copies as usize)
}

/// `v[i]` for the `i` with `keep[i]`, in order (all of `v` past `keep`'s end).
fn retain<T>(v: &mut Vec<T>, keep: &[bool]) {
    let mut i = 0;
    v.retain(|_| {
        i += 1;
        keep.get(i - 1).copied().unwrap_or(true)
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn permute_matches_a_gather() {
        // A permutation with cycles of several lengths and fixed points.
        let order: Vec<u32> = vec![3, 0, 1, 2, 4, 6, 5, 9, 7, 8];
        let mut v: Vec<u32> = (100..110).collect();
        let mut w: Vec<[f64; 3]> = (0..10).map(|i| [i as f64, -(i as f64), 0.5]).collect();
        let want: Vec<u32> = order.iter().map(|&i| v[i as usize]).collect();
        let want_w: Vec<[f64; 3]> = order.iter().map(|&i| w[i as usize]).collect();
        permute(
            &mut [&mut Held(&mut v, None), &mut Held(&mut w, None)],
            &order,
        );
        assert_eq!(v, want);
        assert_eq!(w, want_w);
    }

    #[test]
    fn spatial_order_keeps_every_point_and_is_local() {
        // A grid in scrambled order: after sorting, the set of points is the
        // same, `order` names where each came from, and consecutive points are
        // close (a Morton walk of an 8^3 grid steps one cell far mostly).
        let mut pts = Vec::new();
        for i in 0..512u32 {
            let j = (i * 197) % 512;
            pts.push([(j % 8) as f64, (j / 8 % 8) as f64, (j / 64) as f64]);
        }
        let prepared = |pts: &[[f64; 3]]| {
            prepare(
                "grid".into(),
                Cloud {
                    positions: pts.to_vec(),
                    ..Cloud::default()
                },
            )
            .unwrap()
        };
        // Below the threshold the order is kept.
        assert!(prepared(&pts).order.is_none());
        assert_eq!(prepared(&pts).duplicates, 0);
        // Above it (the grid's points, repeated, each copy shifted by a
        // hair so that none is merged as a duplicate) it is spatial.
        let copies = SPATIAL_ORDER_FROM.div_ceil(512);
        let hair = |c: usize, p: [f64; 3]| [p[0], p[1], p[2] + c as f64 * 1e-6];
        let big: Vec<[f64; 3]> = (0..copies)
            .flat_map(|c| pts.iter().map(move |&p| hair(c, p)))
            .collect();
        let p = prepared(&big);
        let pts = big;
        let order = p.order.as_ref().unwrap();
        let mut seen = vec![false; pts.len()];
        for (i, &o) in order.iter().enumerate() {
            assert_eq!(p.original[i], pts[o as usize]);
            assert!(!seen[o as usize]);
            seen[o as usize] = true;
        }
        let steps = p
            .original
            .windows(2)
            .filter(|w| ((0..3).map(|a| (w[0][a] - w[1][a]).abs()).sum::<f64>() - 1.0).abs() < 1e-3)
            .count();
        // Copies of a point sit together: a step of about 0 or 1 almost always.
        let near = p
            .original
            .windows(2)
            .filter(|w| (0..3).map(|a| (w[0][a] - w[1][a]).abs()).sum::<f64>() <= 1.001)
            .count();
        assert!(
            near > pts.len() * 9 / 10,
            "only {near} near steps of {} ({steps} unit)",
            pts.len()
        );
    }
}
