//! Quality of a reconstructed mesh against the point cloud it came from.
//!
//! [`evaluate`] measures, in `f64` and in the file's units:
//! - **point -> mesh**: the exact distance from every input point to the nearest
//!   triangle (Ericsson's closest point on a triangle), found through a uniform grid of
//!   triangle bounding boxes with a ring search that stops only when no unvisited cell
//!   can hold anything closer, so the result equals a brute-force scan;
//! - **mesh -> points**: the distance from area-uniform surface samples (seeded, so
//!   the same input gives the same numbers) to the nearest input point, through the same
//!   grid over the points;
//! - **Chamfer** (mean of the two means) and **Hausdorff** (max of the two maxima);
//! - **topology**: edges, boundary and non-manifold edges, non-manifold vertices (more
//!   than one fan of faces), components, orientation consistency, Euler characteristic,
//!   degenerate and duplicate faces;
//! - **validity**: pairs of faces that intersect other than where they share vertices
//!   by index (exact predicates), coincident vertices, folded edges, small closed
//!   components beside a large one ("bubbles"), the genus of each closed component, and
//!   the verdict [`Evaluation::is_valid_solid`];
//! - **triangle quality**: percentiles of the minimum angle of each face.
//!
//! Cost: O((P + S) · c + F · k + F log F) time, where P points and S samples each visit
//! `c` grid items on average (a few dozen on scanned models) and each face is tested
//! against the `k` faces whose bounding boxes overlap its own (a dozen or two on a
//! mesh), and O(P + S + F) memory.
//! Queries are spread over the available cores; results do not depend on how many.

mod distance;
mod grid;
mod intersect;
mod quality;
mod topology;
mod validity;

use crate::geom::{cross, dot, sub};
use crate::progress::run_tasks;
use distance::{diagonal, mesh_to_point_distances, point_to_mesh_distances, stats};
pub use distance::{dist2_point_triangle, sample_surface};
pub use intersect::self_intersecting_pairs;
use intersect::Crossings;
pub use quality::min_angle_deg;
use quality::quality;
use serde::Serialize;
use topology::topology;
use validity::validity;
use vsaqem_core::Task;

/// Parts the crossing test of [`check_solid_with`] is cut into (ranges of its
/// grid's layers, each under the test's limits), run beside the topology.
const CROSSING_PARTS: usize = 4;

/// Surface samples of the mesh -> points direction unless told otherwise.
pub const DEFAULT_SAMPLES: usize = 100_000;
/// Seed of the surface sampling: fixed, so evaluations are reproducible.
pub const SAMPLE_SEED: u64 = 0x5EED_0000_0000_0001;
/// Points farther than this fraction of the points' bounding-box diagonal from the
/// mesh are counted in [`PointToMesh::far`].
pub const FAR_FRACTION: f64 = 0.01;
/// A face whose doubled area is at most this fraction of its longest edge squared
/// (i.e. whose largest angle is within about 1e-12 rad of 180°) counts as zero area.
pub const ZERO_AREA: f64 = 1e-12;
/// Two faces on an edge are folded when their normals, oriented consistently, are more
/// than this many degrees apart: they lie almost on top of each other.
pub const FOLD_DEG: f64 = 180.0 - vsaqem_core::meshing::intersect::FOLD_DEGREES;
/// A closed component with fewer faces than this is a bubble when the mesh has a
/// component [`BUBBLE_RATIO`] times larger.
pub const BUBBLE_FACES: usize = 20;
/// See [`BUBBLE_FACES`].
pub const BUBBLE_RATIO: usize = 10;

/// Summary of a set of distances (file units). All NaN when the set is empty.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Stats {
    /// Number of distances.
    pub count: usize,
    /// Largest distance.
    pub max: f64,
    /// Mean distance.
    pub mean: f64,
    /// Root mean square distance.
    pub rms: f64,
    /// 99th percentile (nearest rank: the smallest value with at least 99 % of the
    /// set at or below it).
    pub p99: f64,
}

/// Distances from the input points to the mesh surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointToMesh {
    /// One distance per input point.
    pub stats: Stats,
    /// Points farther than [`FAR_FRACTION`] of the diagonal from the mesh.
    pub far: usize,
}

/// Combinatorial checks of the triangle list.
///
/// Faces with an index out of range are counted in `invalid_faces` and left out of
/// everything else. Faces with a repeated index are counted as degenerate and left out
/// of the combinatorial counts (edges, fans, components, orientation, Euler), which use
/// the remaining faces ("proper faces") and the vertices they reference.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Topology {
    /// Vertices in the vertex list.
    pub vertices: usize,
    /// Faces in the triangle list.
    pub faces: usize,
    /// Faces with an index `>= vertices`.
    pub invalid_faces: usize,
    /// Vertices referenced by a proper face.
    pub referenced_vertices: usize,
    /// Vertices referenced by no proper face (isolated or only in degenerate faces).
    pub unreferenced_vertices: usize,
    /// Distinct undirected edges of the proper faces.
    pub edges: usize,
    /// Edges with exactly one face.
    pub boundary_edges: usize,
    /// Edges with three or more faces.
    pub non_manifold_edges: usize,
    /// Referenced vertices whose incident faces form more than one fan (faces linked
    /// through edges incident to the vertex).
    pub non_manifold_vertices: usize,
    /// Connected components of proper faces, linked through shared edges.
    pub components: usize,
    /// Edges with two faces that traverse it in the same direction.
    pub inconsistent_edges: usize,
    /// `referenced_vertices - edges + proper faces`.
    pub euler: i64,
    /// Faces with a repeated index, a non-finite coordinate or zero area (see
    /// [`ZERO_AREA`]).
    pub degenerate_faces: usize,
    /// Faces with the same vertex set as an earlier face.
    pub duplicate_faces: usize,
}

impl Topology {
    /// A closed, edge- and vertex-manifold, consistently oriented surface.
    pub fn is_closed_manifold(&self) -> bool {
        self.boundary_edges == 0
            && self.non_manifold_edges == 0
            && self.non_manifold_vertices == 0
            && self.inconsistent_edges == 0
    }
}

/// Geometric checks of a solid, beyond the combinatorics of [`Topology`].
///
/// Faces with a repeated index, a non-finite coordinate or zero area (all counted in
/// [`Topology::degenerate_faces`]) are left out of the intersection test.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Validity {
    /// Pairs of faces that meet anywhere other than along the edge or at the vertex
    /// they share by index (core's `faces_intersect`); exact. Touching counts, so does a
    /// vertex of one at the position of a vertex of the other with another index.
    pub self_intersecting_pairs: usize,
    /// Whether the self-intersection test stopped at its limits (faces piled
    /// in one place, such as many copies of a triangle) before testing every
    /// candidate pair: `self_intersecting_pairs` is then a lower bound, and
    /// the mesh is not taken for a valid solid.
    pub self_intersection_stopped: bool,
    /// Vertices of proper faces at exactly the position of another such vertex,
    /// counting all but one per position.
    pub coincident_vertices: usize,
    /// Edges whose two faces (or any two of its faces) lie almost on top of each
    /// other: normals, oriented consistently, more than [`FOLD_DEG`] apart.
    pub folded_edges: usize,
    /// Closed components (no boundary edge) of fewer than [`BUBBLE_FACES`] faces in a
    /// mesh with a component at least [`BUBBLE_RATIO`] times larger.
    pub bubbles: usize,
    /// Faces of those bubbles.
    pub bubble_faces: usize,
    /// Components without a boundary edge.
    pub closed_components: usize,
    /// The genus of each closed, consistently oriented, edge- and vertex-manifold
    /// component, `(2 - χ) / 2` with its own Euler characteristic χ, the component with
    /// most faces first: `[0]` for a sphere, `[1]` for a torus.
    pub genus: Vec<u32>,
}

impl Validity {
    /// The count of self-intersecting pairs for a report: the number, or
    /// "N or more" when the test stopped at its limits.
    pub fn crossings_text(&self) -> String {
        if self.self_intersection_stopped {
            format!(
                "{} or more (the test stopped at its limit: faces piled in one place)",
                self.self_intersecting_pairs
            )
        } else {
            self.self_intersecting_pairs.to_string()
        }
    }

    /// The sum of [`Validity::genus`]: the handles of the closed components.
    pub fn handles(&self) -> u64 {
        self.genus.iter().map(|&g| u64::from(g)).sum()
    }
}

/// Minimum angle per face, in degrees (0 for degenerate faces). NaN without faces.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Quality {
    /// Smallest minimum angle.
    #[serde(rename = "min_angle_min")]
    pub min: f64,
    /// 1st percentile (nearest rank).
    #[serde(rename = "min_angle_p1")]
    pub p1: f64,
    /// 5th percentile.
    #[serde(rename = "min_angle_p5")]
    pub p5: f64,
    /// Median.
    #[serde(rename = "min_angle_p50")]
    pub p50: f64,
}

/// Everything [`evaluate`] measures. Distances are in file units; divide by
/// `diagonal` (or use [`Evaluation::rel`]) for fractions of the points' extent.
#[derive(Clone, Debug, PartialEq)]
pub struct Evaluation {
    /// Input points.
    pub points: usize,
    /// Bounding-box diagonal of the input points.
    pub diagonal: f64,
    /// Input points -> mesh surface.
    pub point_to_mesh: PointToMesh,
    /// Surface samples -> nearest input point (`stats.count` samples).
    pub mesh_to_points: Stats,
    /// Mean of the two mean distances.
    pub chamfer: f64,
    /// Max of the two maximum distances.
    pub hausdorff: f64,
    /// Signed volume enclosed by the faces (file units cubed): positive when a closed
    /// mesh's faces are counter-clockwise seen from outside, negative when inward.
    pub signed_volume: f64,
    /// Combinatorial checks.
    pub topology: Topology,
    /// Geometric checks of a solid.
    pub validity: Validity,
    /// Minimum-angle distribution.
    pub quality: Quality,
}

impl Evaluation {
    /// `d` as a fraction of the points' bounding-box diagonal.
    pub fn rel(&self, d: f64) -> f64 {
        d / self.diagonal
    }

    /// A sound surface ([`Solid::is_sound`]).
    pub fn is_sound(&self) -> bool {
        sound(&self.topology, &self.validity)
    }

    /// A valid solid ([`Solid::is_valid_solid`]).
    pub fn is_valid_solid(&self, genus: Option<u64>) -> bool {
        valid_solid(&self.topology, &self.validity, genus)
    }
}

/// The checks of a mesh that need no point cloud: its combinatorics and whether
/// it is a valid solid ([`check_solid`]).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Solid {
    /// Combinatorial checks.
    pub topology: Topology,
    /// Geometric checks of a solid.
    pub validity: Validity,
}

impl Solid {
    /// A sound surface, open or closed: faces, all proper (no degenerate,
    /// duplicate or out-of-range face), edge- and vertex-manifold and
    /// consistently oriented, with no self-intersecting pair, coincident vertex,
    /// folded edge or bubble.
    pub fn is_sound(&self) -> bool {
        sound(&self.topology, &self.validity)
    }

    /// A valid solid: sound ([`Solid::is_sound`]) and closed (no boundary
    /// edge, so a closed manifold: [`Topology::is_closed_manifold`]); and, when
    /// `genus` is given, [`Validity::handles`] equal to it.
    pub fn is_valid_solid(&self, genus: Option<u64>) -> bool {
        valid_solid(&self.topology, &self.validity, genus)
    }
}

fn sound(t: &Topology, v: &Validity) -> bool {
    t.faces > 0
        && t.non_manifold_edges == 0
        && t.non_manifold_vertices == 0
        && t.inconsistent_edges == 0
        && t.degenerate_faces == 0
        && t.duplicate_faces == 0
        && t.invalid_faces == 0
        && v.self_intersecting_pairs == 0
        && !v.self_intersection_stopped
        && v.coincident_vertices == 0
        && v.folded_edges == 0
        && v.bubbles == 0
}

fn valid_solid(t: &Topology, v: &Validity, genus: Option<u64>) -> bool {
    sound(t, v) && t.is_closed_manifold() && genus.is_none_or(|g| g == v.handles())
}

/// A task that calls `f` and keeps what it returns.
struct Job<F, R> {
    f: F,
    out: Option<R>,
}

impl<F: Fn() -> R, R> Job<F, R> {
    fn new(f: F) -> Self {
        Job { f, out: None }
    }

    /// What `f` returned when run, or returns now.
    fn finish(self) -> R {
        let Job { f, out } = self;
        out.unwrap_or_else(f)
    }
}

impl<F: Fn() -> R + Send, R: Send> Task for Job<F, R> {
    fn run(&mut self) {
        self.out = Some((self.f)());
    }
}

/// The topology and validity checks of [`evaluate`] alone, for a mesh without
/// its point cloud (the mesh a run writes). Faces with an index out of range
/// are counted in [`Topology::invalid_faces`] and left out of the rest.
/// O(F log F) plus the self-intersection test: each face against the faces
/// whose bounding boxes overlap its own.
pub fn check_solid(vertices: &[[f64; 3]], triangles: &[[u32; 3]]) -> Solid {
    check_solid_with(vertices, triangles, &|tasks| run_tasks(None, tasks))
}

/// [`check_solid`], with the self-intersection test in one task and the
/// topology in another, both handed to `run` at once (which may run them on
/// two threads; the result is the same).
pub fn check_solid_with(
    vertices: &[[f64; 3]],
    triangles: &[[u32; 3]],
    run: &dyn Fn(&mut [&mut dyn Task]),
) -> Solid {
    let nv = vertices.len();
    let valid: Vec<[u32; 3]> = triangles
        .iter()
        .copied()
        .filter(|t| t.iter().all(|&i| (i as usize) < nv))
        .collect();
    // The crossing test cut into ranges of its grid's layers, beside the
    // topology: one task for it left the other thread idle most of the check.
    let candidates = intersect::Candidates::new(vertices, &valid);
    let layers = candidates.layers();
    let parts = CROSSING_PARTS.min(layers.max(1));
    let (candidates, valid_ref) = (&candidates, &valid);
    let mut crossings: Vec<_> = (0..parts)
        .map(|k| {
            let range = layers * k / parts..layers * (k + 1) / parts;
            Job::new(move || candidates.crossings_in(valid_ref, range.clone()))
        })
        .collect();
    let mut surface = Job::new(|| topology(vertices, valid_ref));
    let mut tasks: Vec<&mut dyn Task> = crossings.iter_mut().map(|j| j as &mut dyn Task).collect();
    tasks.push(&mut surface);
    run(&mut tasks);
    drop(tasks);
    let crossings = crossings.into_iter().map(Job::finish).fold(
        Crossings {
            pairs: 0,
            complete: true,
        },
        |a, b| Crossings {
            pairs: a.pairs + b.pairs,
            complete: a.complete && b.complete,
        },
    );
    let surface = surface.finish();
    let validity = validity(vertices, &valid, &surface, crossings);
    let mut topology = surface.topology;
    topology.faces = triangles.len();
    topology.invalid_faces = triangles.len() - valid.len();
    Solid { topology, validity }
}

/// Evaluates the mesh (`vertices`, `triangles`) against `points`, with `samples`
/// surface samples for the mesh -> points direction ([`DEFAULT_SAMPLES`] is the usual
/// choice). Never panics: an empty point set or a mesh without area gives NaN distances.
pub fn evaluate(
    points: &[[f64; 3]],
    vertices: &[[f64; 3]],
    triangles: &[[u32; 3]],
    samples: usize,
) -> Evaluation {
    let nv = vertices.len();
    let valid: Vec<[u32; 3]> = triangles
        .iter()
        .copied()
        .filter(|t| t.iter().all(|&i| (i as usize) < nv))
        .collect();
    let tris: Vec<[[f64; 3]; 3]> = valid
        .iter()
        .map(|t| t.map(|i| vertices[i as usize]))
        .collect();

    let diagonal = diagonal(points);
    let to_mesh = point_to_mesh_distances(points, &tris);
    let far = to_mesh
        .iter()
        .filter(|&&d| d > FAR_FRACTION * diagonal)
        .count();
    let to_mesh = stats(to_mesh);
    let to_points = stats(mesh_to_point_distances(points, &tris, samples));

    let Solid { topology, validity } = check_solid(vertices, triangles);
    Evaluation {
        points: points.len(),
        diagonal,
        point_to_mesh: PointToMesh {
            stats: to_mesh,
            far,
        },
        mesh_to_points: to_points,
        chamfer: 0.5 * (to_mesh.mean + to_points.mean),
        hausdorff: to_mesh.max.max(to_points.max),
        signed_volume: tris
            .iter()
            .map(|t| dot(t[0], cross(t[1], t[2])) / 6.0)
            .sum(),
        topology,
        validity,
        quality: quality(&tris),
    }
}

/// Whether a triangle has (numerically) zero area; see [`ZERO_AREA`].
pub(crate) fn zero_area(t: &[[f64; 3]; 3]) -> bool {
    let (ab, ac, bc) = (sub(t[1], t[0]), sub(t[2], t[0]), sub(t[2], t[1]));
    let n = cross(ab, ac);
    let longest = dot(ab, ab).max(dot(ac, ac)).max(dot(bc, bc));
    dot(n, n).sqrt() <= ZERO_AREA * longest
}

/// `n` points uniform in the cube of side `scale` around the origin (seeded).
#[cfg(test)]
fn rng_points(n: usize, seed: u64, scale: f64) -> Vec<[f64; 3]> {
    let mut r = vsaqem_core::rng::Rng::from_state(seed);
    (0..n)
        .map(|_| [0; 3].map(|_| (r.unit_f64() - 0.5) * scale))
        .collect()
}
