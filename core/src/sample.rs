//! Generated point clouds: the shapes the tests, the benchmarks and the built-in
//! demo use (spheres, tori, boxes with sharp edges, ...), deterministic by seed.
//! They fill a caller-owned slice, so firmware can use them too.

use crate::math::V3;
use crate::rng::Rng;
use core::f64::consts::PI;

/// A shape to sample.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum Shape {
    /// Unit sphere at the origin.
    Sphere,
    /// Torus around z: major radius 0.7, minor 0.25.
    Torus,
    /// Axis-aligned box with half-extents (0.9, 0.6, 0.4): 12 sharp edges, 8 corners.
    Box,
    /// Closed cylinder around z: radius 0.5, half-height 0.8 (sharp rims).
    Cylinder,
    /// The built-in demo: a box with a cylinder fused on top and a rounded side,
    /// sharp edges and curved parts together.
    Demo,
    /// Open: the upper half of the unit sphere (border: the unit circle at z = 0).
    Hemisphere,
    /// Open: the side of a cylinder of radius 0.6 for |z| <= 0.8, no caps (border:
    /// two circles).
    Tube,
    /// Open: the height field z = 0.15 sin(πx) cos(πy/2) over [-1, 1]^2 (border:
    /// the square's outline lifted onto it).
    Wave,
    /// Open: the unit sphere without the cap z > 0.7 (border: the circle of radius
    /// √0.51 at z = 0.7).
    HoledSphere,
    /// Several objects: a sphere of radius 0.45 at (-0.5, 0, 0) and a cube of
    /// half-edge 0.3 at (0.5, 0, 0) (0.25 apart), sampled by area, plus a stray
    /// fragment: [`scene_fragment`]`(n)` points (40 from 1000 points on) on a
    /// sphere of radius 0.04 at (0, 0.7, 0), the last points of the cloud.
    Scene,
}

/// Points of [`Shape::Scene`]'s stray fragment in a cloud of `n`: 40, or 4 % of
/// smaller clouds.
pub fn scene_fragment(n: usize) -> usize {
    if n >= 1000 {
        40
    } else {
        n / 25
    }
}

/// Centre of [`Shape::Scene`]'s sphere (radius 0.45).
pub const SCENE_SPHERE: [f64; 3] = [-0.5, 0.0, 0.0];
/// Centre of [`Shape::Scene`]'s cube (half-edge 0.3).
pub const SCENE_CUBE: [f64; 3] = [0.5, 0.0, 0.0];
/// Centre of [`Shape::Scene`]'s stray fragment (a sphere of radius 0.04).
pub const SCENE_FRAGMENT: [f64; 3] = [0.0, 0.7, 0.0];

/// A point of [`Shape::Scene`]: on the fragment when `fragment`, else on the
/// sphere or the cube with probability proportional to their areas.
fn scene_surface(rng: &mut Rng, fragment: bool) -> [f64; 3] {
    let at = |c: [f64; 3], r: f64, p: [f64; 3]| [c[0] + r * p[0], c[1] + r * p[1], c[2] + r * p[2]];
    if fragment {
        return at(SCENE_FRAGMENT, 0.04, unit_sphere(rng));
    }
    let sphere = 4.0 * PI * 0.45 * 0.45;
    let cube = 24.0 * 0.3 * 0.3;
    if rng.unit_f64() * (sphere + cube) < sphere {
        at(SCENE_SPHERE, 0.45, unit_sphere(rng))
    } else {
        at(SCENE_CUBE, 1.0, box_surface(rng, [0.3; 3]))
    }
}

impl Shape {
    /// Parse a lower-case name.
    pub fn from_name(s: &str) -> Option<Shape> {
        Some(match s {
            "sphere" => Shape::Sphere,
            "torus" => Shape::Torus,
            "box" => Shape::Box,
            "cylinder" => Shape::Cylinder,
            "demo" => Shape::Demo,
            "hemisphere" => Shape::Hemisphere,
            "tube" => Shape::Tube,
            "wave" => Shape::Wave,
            "holed-sphere" => Shape::HoledSphere,
            "scene" => Shape::Scene,
            _ => return None,
        })
    }
}

fn unit_sphere(rng: &mut Rng) -> [f64; 3] {
    // Archimedes: uniform z and angle give a uniform point on the sphere.
    let z = 2.0 * rng.unit_f64() - 1.0;
    let t = 2.0 * PI * rng.unit_f64();
    let r = libm::sqrt((1.0 - z * z).max(0.0));
    [r * libm::cos(t), r * libm::sin(t), z]
}

fn box_surface(rng: &mut Rng, h: [f64; 3]) -> [f64; 3] {
    let areas = [h[1] * h[2], h[0] * h[2], h[0] * h[1]];
    let total = areas[0] + areas[1] + areas[2];
    let mut pick = rng.unit_f64() * total;
    let mut axis = 2;
    for (a, &ar) in areas.iter().enumerate() {
        if pick < ar {
            axis = a;
            break;
        }
        pick -= ar;
    }
    let mut p = [0.0; 3];
    for a in 0..3 {
        p[a] = (2.0 * rng.unit_f64() - 1.0) * h[a];
    }
    p[axis] = if rng.unit_f64() < 0.5 {
        -h[axis]
    } else {
        h[axis]
    };
    p
}

fn cylinder_surface(rng: &mut Rng, r: f64, hh: f64) -> [f64; 3] {
    let side = 2.0 * PI * r * 2.0 * hh;
    let cap = PI * r * r;
    let pick = rng.unit_f64() * (side + 2.0 * cap);
    let t = 2.0 * PI * rng.unit_f64();
    if pick < side {
        [
            r * libm::cos(t),
            r * libm::sin(t),
            (2.0 * rng.unit_f64() - 1.0) * hh,
        ]
    } else {
        let rr = r * libm::sqrt(rng.unit_f64());
        let z = if pick < side + cap { hh } else { -hh };
        [rr * libm::cos(t), rr * libm::sin(t), z]
    }
}

fn torus_surface(rng: &mut Rng, big: f64, small: f64) -> [f64; 3] {
    // Rejection on the tube angle gives uniform area density.
    loop {
        let u = 2.0 * PI * rng.unit_f64();
        let v = 2.0 * PI * rng.unit_f64();
        let w = (big + small * libm::cos(v)) / (big + small);
        if rng.unit_f64() <= w {
            let ring = big + small * libm::cos(v);
            return [
                ring * libm::cos(u),
                ring * libm::sin(u),
                small * libm::sin(v),
            ];
        }
    }
}

/// The demo: a box `[-0.8,0.8]x[-0.5,0.5]x[-0.5,0.1]` with a vertical cylinder
/// (radius 0.35, up to z = 0.6) standing on it: planes, sharp convex and concave
/// edges, and curved parts. Points are sampled by area, and only those on the
/// outer surface of the union are kept.
fn demo_surface(rng: &mut Rng) -> [f64; 3] {
    let bh = [0.8, 0.5, 0.3];
    let bc = [0.0, 0.0, -0.2];
    let (r, z0, z1) = (0.35, 0.1, 0.6);
    let box_area = 8.0 * (bh[0] * bh[1] + bh[0] * bh[2] + bh[1] * bh[2]);
    let cyl_side = 2.0 * PI * r * (z1 - z0);
    let cyl_top = PI * r * r;
    loop {
        let pick = rng.unit_f64() * (box_area + cyl_side + cyl_top);
        let p = if pick < box_area {
            let q = box_surface(rng, bh);
            [q[0] + bc[0], q[1] + bc[1], q[2] + bc[2]]
        } else if pick < box_area + cyl_side {
            let t = 2.0 * PI * rng.unit_f64();
            [
                r * libm::cos(t),
                r * libm::sin(t),
                z0 + rng.unit_f64() * (z1 - z0),
            ]
        } else {
            let t = 2.0 * PI * rng.unit_f64();
            let rr = r * libm::sqrt(rng.unit_f64());
            [rr * libm::cos(t), rr * libm::sin(t), z1]
        };
        // Drop the part of the box top hidden under the cylinder.
        let on_top = (p[2] - z0).abs() < 1e-12;
        if on_top && p[0] * p[0] + p[1] * p[1] < r * r {
            continue;
        }
        return p;
    }
}

/// `(z, ∂z/∂x, ∂z/∂y)` of the [`Shape::Wave`] height field at `(x, y)`.
pub fn wave(x: f64, y: f64) -> (f64, f64, f64) {
    let (a, b) = (PI * x, 0.5 * PI * y);
    (
        0.15 * libm::sin(a) * libm::cos(b),
        0.15 * PI * libm::cos(a) * libm::cos(b),
        -0.075 * PI * libm::sin(a) * libm::sin(b),
    )
}

/// Area-uniform on the height field: uniform (x, y), kept with probability
/// proportional to the area element.
fn wave_surface(rng: &mut Rng) -> [f64; 3] {
    let most = libm::sqrt(1.0 + (0.15 * PI) * (0.15 * PI) + (0.075 * PI) * (0.075 * PI));
    loop {
        let x = 2.0 * rng.unit_f64() - 1.0;
        let y = 2.0 * rng.unit_f64() - 1.0;
        let (z, zx, zy) = wave(x, y);
        if rng.unit_f64() * most <= libm::sqrt(1.0 + zx * zx + zy * zy) {
            return [x, y, z];
        }
    }
}

/// Fill `out` with points sampled uniformly by area on `shape`, plus isotropic
/// Gaussian noise of standard deviation `noise` (absolute units).
pub fn fill(shape: Shape, seed: u64, noise: f64, out: &mut [V3]) {
    let mut rng = Rng::new(seed);
    let fragment_from = out.len() - scene_fragment(out.len());
    for (i, o) in out.iter_mut().enumerate() {
        let p = match shape {
            Shape::Sphere => unit_sphere(&mut rng),
            Shape::Torus => torus_surface(&mut rng, 0.7, 0.25),
            Shape::Box => box_surface(&mut rng, [0.9, 0.6, 0.4]),
            Shape::Cylinder => cylinder_surface(&mut rng, 0.5, 0.8),
            Shape::Demo => demo_surface(&mut rng),
            Shape::Hemisphere => {
                let p = unit_sphere(&mut rng);
                [p[0], p[1], p[2].abs()]
            }
            Shape::Tube => {
                let t = 2.0 * PI * rng.unit_f64();
                let z = (2.0 * rng.unit_f64() - 1.0) * 0.8;
                [0.6 * libm::cos(t), 0.6 * libm::sin(t), z]
            }
            Shape::Wave => wave_surface(&mut rng),
            Shape::HoledSphere => loop {
                let p = unit_sphere(&mut rng);
                if p[2] <= 0.7 {
                    break p;
                }
            },
            Shape::Scene => scene_surface(&mut rng, i >= fragment_from),
        };
        let mut q = [0.0f32; 3];
        for a in 0..3 {
            let g = if noise > 0.0 {
                noise * gaussian(&mut rng)
            } else {
                0.0
            };
            q[a] = (p[a] + g) as f32;
        }
        *o = q;
    }
}

/// Standard normal by Box-Muller.
pub fn gaussian(rng: &mut Rng) -> f64 {
    let u = rng.unit_f64().max(1e-300);
    let v = rng.unit_f64();
    libm::sqrt(-2.0 * libm::log(u)) * libm::cos(2.0 * PI * v)
}
