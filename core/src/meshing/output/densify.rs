//! Vertices where the mesh is farthest from the data: error-driven refinement
//! without a new selection.
//!
//! A few points usually lie much farther from the mesh than the rest (a tip
//! the faces cut across, a crease the vertices straddle, a border the faces
//! stop short of). Each pass takes, cluster by cluster, the farthest point
//! beyond the threshold (the 99th percentile of the distances) that at least
//! half its neighbours back (each at least half as far, or each tangent plane
//! within half that distance of it: a part of the surface the mesh misses, not
//! a stray point), farthest first, and makes it a vertex
//! of the face (or edge) nearest to it, by the same checked split that puts
//! skipped clusters into the mesh (no degenerate, turned-over, crossing or
//! folded face, judged where every vertex goes back to when untangling).
//! Splits in one pass touch disjoint faces. The next pass measures the points
//! of the touched clusters again. The caller then fits the vertices and puts
//! those of any tangled face back home (`Growing::untangle`).
//!
//! Memory: scratch only, O(clusters + vertices) for the candidates and marks,
//! plus a face grid per pass. Cost per pass: O(faces) per split, plus a grid
//! and the queries of the touched clusters' points. The queries and each
//! cluster's farthest point are parallel tasks (over ranges of clusters and of
//! the farthest points), the grid and the splits on the calling thread.

use super::insert::split_at;
use super::repair::mark_tangles;
use crate::arena::{atomic_f32_bits, Alloc};
use crate::clustering::knn::Neighbours;
use crate::clustering::quadric::{plane_eval, plane_weight, Planes};
use crate::error::Result;
use crate::math::{closest_on_triangle, norm, sub, V3};
use crate::meshing::candidates::Members;
use crate::meshing::face_grid::FaceGrid;
use crate::parallel;
use crate::progress::Progress;
use core::sync::atomic::Ordering::Relaxed;

/// How far above the planes' noise floor half a point's distance must be
/// before its neighbours' tangent planes can vouch for it: on the bunny with
/// Gaussian noise of 0.3 % of the diagonal, trusting them at any distance added
/// the whole budget (105 vertices at 1,000 clusters, against 24) for a mesh no
/// nearer the clean surface.
const PLANE_NOISE: f32 = 4.0;

/// Passes of putting the vertices of tangled faces back home at most.
pub const UNTANGLE_PASSES: u32 = 8;
/// Passes of adding vertices at most.
pub const DENSIFY_PASSES: u32 = 8;
/// A cluster's slot of the farthest points when it has none.
const NOT_FAR: (f32, u32, u32) = (0.0, u32::MAX, u32::MAX);

/// A mesh being refined: positions, faces and where each vertex came from,
/// in buffers with room to grow.
pub(super) struct Growing<'s> {
    /// Positions; the first `nv` are the mesh's.
    pub vertices: &'s mut [V3],
    /// Where each vertex goes back to when a face at it crosses another: its
    /// generator, or the point it was made at.
    pub home: &'s mut [V3],
    /// The cluster of each vertex.
    pub vertex_cluster: &'s mut [u32],
    /// Faces; the first `nf` are the mesh's.
    pub triangles: &'s mut [[u32; 3]],
    /// Vertices in use.
    pub nv: usize,
    /// Faces in use.
    pub nf: usize,
}

impl Growing<'_> {
    /// Puts every vertex of a face that crosses another or folds onto its
    /// neighbour back home, again while that changes something (a face put
    /// back can meet one that moved), [`UNTANGLE_PASSES`] times at most.
    /// Returns the vertices moved and the face pairs still tangled after that.
    /// `hooks` run the crossing tests' parallel tasks.
    pub fn untangle<'b, S: Alloc<'b>>(
        &mut self,
        s: &S,
        hooks: &dyn Progress,
    ) -> Result<(u32, u32)> {
        let (nv, nf) = (self.nv, self.nf);
        let (vertices, triangles) = (&mut self.vertices[..nv], &self.triangles[..nf]);
        let home = &self.home[..nv];
        s.scratch(|t| -> Result<(u32, u32)> {
            let cut = t.try_alloc_slice::<bool>(nf, false)?;
            let mut found = mark_tangles(t, triangles, vertices, cut, hooks)?;
            let mut back = 0;
            for _ in 0..UNTANGLE_PASSES {
                if found == 0 {
                    break;
                }
                let mut moved = 0;
                for (f, _) in cut.iter().enumerate().filter(|(_, &c)| c) {
                    for &v in &triangles[f] {
                        let v = v as usize;
                        if vertices[v] != home[v] {
                            vertices[v] = home[v];
                            moved += 1;
                        }
                    }
                }
                if moved == 0 {
                    break;
                }
                back += moved;
                cut.fill(false);
                found = mark_tangles(t, triangles, vertices, cut, hooks)?;
            }
            Ok((back, found))
        })
    }
}

/// Whether point `i`, at distance `e` from the mesh, is part of the surface
/// the mesh misses, not a stray point: at least half its neighbours are at
/// least half as far, or at least half its neighbours' tangent planes pass
/// within half that distance of it (a sparse sample of a curved part the faces
/// cut across; a stray point lies about its whole distance off its neighbours'
/// planes). The planes count only where half the distance is at least
/// [`PLANE_NOISE`] times their noise floor: under noise they are too unsteady
/// to tell. `distances` holds every point's distance to the mesh.
pub(super) fn supported(
    points: &[V3],
    nb: &Neighbours,
    planes: &Planes,
    distances: &[f32],
    i: u32,
    e: f32,
) -> bool {
    let Some(&p) = points.get(i as usize) else {
        return false;
    };
    let steady = 0.5 * e >= PLANE_NOISE * planes.noise;
    let row = nb.knn.get(i as usize * nb.k..(i as usize + 1) * nb.k);
    let (mut far, mut on) = (0, 0);
    for &q in row.unwrap_or(&[]) {
        if distances.get(q as usize).is_some_and(|&x| x > e / 2.0) {
            far += 1;
        }
        if let Some(&u) = planes.planes.get(q as usize).filter(|_| steady) {
            let (r, w) = (plane_eval(u, p), plane_weight(u));
            if w > 0.0 && r * r <= 0.25 * e * e * w {
                on += 1;
            }
        }
    }
    2 * far >= nb.k || 2 * on >= nb.k
}

/// Whether point `i`, at distance `e` from the mesh, is part of the surface
/// for a refinement round. Only where half the distance is at least
/// [`PLANE_NOISE`] times the planes' noise floor (under noise, points a few
/// noise widths off the mesh, and their neighbours with them, are not the
/// mesh's fault); then when [`supported`], or when it does not stand apart
/// from its neighbours: its nearest neighbour at most twice as far as theirs
/// are on average. A sparse sample of a thin part the mesh cuts off is spaced
/// like its neighbours; a stray point near a denser surface is not.
pub(super) fn part_of_surface(
    points: &[V3],
    nb: &Neighbours,
    planes: &Planes,
    distances: &[f32],
    i: u32,
    e: f32,
) -> bool {
    if 0.5 * e < PLANE_NOISE * planes.noise {
        return false;
    }
    if supported(points, nb, planes, distances, i, e) {
        return true;
    }
    let nearest = |i: u32| -> Option<f32> {
        let p = *points.get(i as usize)?;
        let &q = nb.knn.get(i as usize * nb.k)?;
        let q = *points.get(q as usize)?;
        Some(norm(sub(p, q)))
    };
    let Some(own) = nearest(i) else {
        return false;
    };
    let row = nb.knn.get(i as usize * nb.k..(i as usize + 1) * nb.k);
    let (mut sum, mut n) = (0.0f32, 0u32);
    for &q in row.unwrap_or(&[]) {
        if let Some(x) = nearest(q) {
            sum += x;
            n += 1;
        }
    }
    n > 0 && own <= 2.0 * sum / n as f32
}

/// What densifying did.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Densified {
    /// Vertices added.
    pub added: u32,
    /// Passes that added some.
    pub passes: u32,
}

/// Adds at most `budget` vertices to `mesh` at the points farther than
/// `threshold` from it (see the module docs), in [`DENSIFY_PASSES`] passes at
/// most. A point farther than `bound` (an error bound: infinite for none)
/// needs no neighbours' support, and `bound` lowers `threshold` when nearer:
/// the caller asked for every point within it. `distances` holds each point's distance to the mesh on entry; after
/// each pass those of the points in the clusters of the vertices it touched
/// are measured again (the others change little), so on return they are
/// stale: measure again after moving the vertices. The buffers of `mesh` must
/// have room for `budget` more vertices and `2 × budget` more faces. `hooks`
/// run the parallel tasks.
#[allow(clippy::too_many_arguments)]
pub(super) fn densify<'b, S: Alloc<'b>>(
    s: &S,
    points: &[V3],
    members: &Members,
    nb: &Neighbours,
    planes: &Planes,
    mesh: &mut Growing,
    distances: &mut [f32],
    budget: usize,
    threshold: f32,
    bound: f32,
    tol: f32,
    hooks: &dyn Progress,
) -> Result<Densified> {
    let threshold = threshold.min(bound);
    let mut out = Densified::default();
    let budget = budget
        .min(mesh.vertices.len().saturating_sub(mesh.nv))
        .min(mesh.home.len().saturating_sub(mesh.nv))
        .min(mesh.vertex_cluster.len().saturating_sub(mesh.nv))
        .min(mesh.triangles.len().saturating_sub(mesh.nf) / 2);
    if budget == 0 || threshold.is_nan() || threshold < 0.0 || members.is_empty() {
        return Ok(out);
    }
    s.scratch(|s| -> Result<()> {
        let far = s.try_alloc_slice::<(f32, u32, u32)>(members.len(), (0.0, 0, 0))?;
        let at = s.try_alloc_slice::<(u32, [f32; 3])>(members.len(), (u32::MAX, [0.0; 3]))?;
        let touched = s.try_alloc_slice::<bool>(mesh.nv + budget, false)?;
        let again = s.try_alloc_slice::<bool>(members.len(), false)?;
        for _ in 0..DENSIFY_PASSES {
            let left = budget - out.added as usize;
            if left == 0 {
                break;
            }
            // One grid per pass: the points of the clusters whose vertices the
            // pass before touched are measured again, then every candidate's
            // nearest face and its coordinates there are found (before any
            // split: splits in a pass touch disjoint faces).
            let (nv, nf) = (mesh.nv, mesh.nf);
            let count = s.scratch(|g| -> Result<usize> {
                let grid =
                    FaceGrid::try_new_in(g, &mesh.vertices[..nv], &mesh.triangles[..nf], hooks)?;
                // Parallel tasks over ranges of clusters; each point is in
                // one cluster, so each distance is set by one task.
                let fresh = atomic_f32_bits(distances);
                let again = &*again;
                parallel::ranges(hooks, members.len(), |clusters| {
                    for j in clusters.filter(|&j| again[j]) {
                        for &i in members.of(j) {
                            if let (Some(&p), Some(d)) =
                                (points.get(i as usize), fresh.get(i as usize))
                            {
                                let e = grid
                                    .nearest(p)
                                    .map_or(f32::INFINITY, |(_, d2)| libm::sqrtf(d2));
                                d.store(e.to_bits(), Relaxed);
                            }
                        }
                    }
                });
                let distances = &*distances;
                // Each cluster's farthest point beyond the threshold that is
                // part of the surface the mesh misses ([`supported`]), or
                // beyond the bound. (distance, point, cluster), farthest
                // first (lower point index among equals).
                let supported =
                    |i: u32, e: f32| e > bound || supported(points, nb, planes, distances, i, e);
                // In parallel tasks over ranges of clusters, each into its
                // cluster's slot of `far` (`NOT_FAR` for none), then gathered
                // in cluster order.
                let m = members.len().min(far.len());
                parallel::rows(hooks, &mut far[..m], 1, |clusters, out| {
                    for (j, slot) in clusters.zip(out.iter_mut()) {
                        let mut best: Option<(f32, u32)> = None;
                        for &i in members.of(j) {
                            let Some(&e) = distances.get(i as usize) else {
                                continue;
                            };
                            let better = match best {
                                None => true,
                                Some((x, b)) => e > x || (e == x && i < b),
                            };
                            if e > threshold && e.is_finite() && better && supported(i, e) {
                                best = Some((e, i));
                            }
                        }
                        *slot = match best {
                            Some((e, i)) if (i as usize) < points.len() => (e, i, j as u32),
                            _ => NOT_FAR,
                        };
                    }
                });
                let mut count = 0;
                for j in 0..m {
                    if far[j].1 != NOT_FAR.1 {
                        far[count] = far[j];
                        count += 1;
                    }
                }
                let far = &mut far[..count];
                far.sort_unstable_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
                let far = &*far;
                let (vertices, triangles) = (&*mesh.vertices, &*mesh.triangles);
                parallel::rows(hooks, &mut at[..count], 1, |items, out| {
                    for (k, a) in items.zip(out.iter_mut()) {
                        let p = points[far[k].1 as usize];
                        *a = (u32::MAX, [0.0; 3]);
                        if let Some((f, _)) = grid.nearest(p) {
                            let c = triangles[f as usize].map(|v| vertices[v as usize]);
                            *a = (f, closest_on_triangle(p, c[0], c[1], c[2]).1);
                        }
                    }
                });
                Ok(count)
            })?;
            let far = &far[..count];
            touched.fill(false);
            let mut added = 0;
            for (&(_, i, j), &(f, bary)) in far.iter().zip(at.iter()) {
                if added == left {
                    break;
                }
                let f = f as usize;
                if f >= mesh.nf || mesh.triangles[f].iter().any(|&v| touched[v as usize]) {
                    continue;
                }
                let v = mesh.nv;
                let p = points[i as usize];
                // Checked where every vertex goes back to when untangling, so
                // that putting them all back always untangles.
                mesh.home[v] = p;
                let before = mesh.nf;
                let old = mesh.triangles[f];
                let Some(n) = split_at(
                    mesh.triangles,
                    mesh.nf,
                    f,
                    bary,
                    v as u32,
                    &mesh.home[..v + 1],
                    tol,
                    // At a point of the data, in its nearest face.
                    &|_| true,
                    hooks,
                ) else {
                    continue;
                };
                mesh.vertices[v] = p;
                mesh.vertex_cluster[v] = j;
                for &u in old.iter().chain(mesh.triangles[before..n].iter().flatten()) {
                    touched[u as usize] = true;
                }
                mesh.nv += 1;
                mesh.nf = n;
                added += 1;
            }
            if added == 0 {
                break;
            }
            out.added += added as u32;
            out.passes += 1;
            // The points of every touched vertex's cluster are measured again
            // at the next pass's start.
            again.fill(false);
            for v in 0..mesh.nv {
                if touched[v] {
                    if let Some(a) = again.get_mut(mesh.vertex_cluster[v] as usize) {
                        *a = true;
                    }
                }
            }
        }
        Ok(())
    })?;
    Ok(out)
}
