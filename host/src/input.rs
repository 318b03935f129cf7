//! Where the points come from: a file, or a built-in generated sample.

use crate::io::{read_cloud, Cloud};
use crate::normalize::Frame;
use crate::progress::StageClock;
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
    Option<&Rows>,
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
    /// Core coordinates <-> file coordinates.
    pub frame: Frame,
    /// Positions as read, in file coordinates.
    pub original: Vec<[f64; 3]>,
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
        normals: None,
    }
}

/// Read `path`, or make the sample when there is no path.
pub fn load(
    path: Option<&Path>,
    shape: Shape,
    points: usize,
    noise: f64,
    seed: u64,
) -> Result<(String, Cloud), String> {
    match path {
        Some(p) => {
            let cloud = read_cloud(p).map_err(|e| e.to_string())?;
            Ok((p.display().to_string(), cloud))
        }
        None => {
            let name = if noise > 0.0 {
                format!(
                    "built-in sample '{}' ({points} points, noise {}% of the diagonal)",
                    shape_name(shape),
                    noise * 100.0
                )
            } else {
                format!("built-in sample '{}' ({points} points)", shape_name(shape))
            };
            Ok((name, sample(shape, points, noise, seed)))
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
        rows: Option<&Rows>,
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

    /// Only the points with `keep[i]` (and their normals), normalised again: the
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
        let frame = Frame::fit(&original);
        Prepared {
            name: self.name,
            points: original.iter().map(|&p| frame.to_core(p)).collect(),
            normals,
            frame,
            original,
        }
    }
}

/// Normalise into core coordinates.
pub fn prepare(name: String, cloud: Cloud) -> Prepared {
    let frame = Frame::fit(&cloud.positions);
    let points = cloud.positions.iter().map(|&p| frame.to_core(p)).collect();
    let normals = cloud
        .normals
        .map(|n| n.iter().map(|v| v.map(|c| c as f32)).collect());
    Prepared {
        name,
        points,
        normals,
        frame,
        original: cloud.positions,
    }
}
