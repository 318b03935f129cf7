//! Faces over gaps in the data: the mesh-to-data half of the distance.
//!
//! Where the clusters straddle a slot or a tunnel narrower than their spacing
//! (the gear's hub-wall slots at 500 clusters: 0.1 wide, 3 points across),
//! the selection joins them by faces straight across it: every point is near
//! the mesh, so the point-to-mesh distance cannot see it, but the faces are far
//! from every point and the tunnel is gone (a wrong genus). Each face is
//! sampled (its centroid, three inner points and its edge midpoints) and each
//! sample's nearest point is found by walking the k-NN graph down from a
//! point of each of the face's clusters (a greedy descent: on a surface
//! sampled as densely as its neighbourhoods it ends at the nearest point or
//! one about as near). A face whose farthest sample is beyond the bound offers
//! the point its walk ended at, on the gap's rim, for a generator, so that the
//! next round's mesh can follow the rim into the tunnel.
//!
//! Only where the data goes on past the rim ([`goes_on`]): a hole in the data
//! (the base of a scanned figure, a patch the scanner never saw) has a rim
//! where the data ends, and a generator there changes nothing but the time.
//!
//! Memory: one entry per face (scratch, the caller's). Cost: O(faces × samples × walk length × k) plus O(k²) per
//! offered point.

use crate::clustering::knn::Neighbours;
use crate::clustering::quadric::Planes;
use crate::math::{dist2, dot, norm, sub, V3};
use crate::meshing::candidates::Members;
use crate::parallel;
use crate::progress::Progress;

/// How far beyond the refinement distance a face must be from the data to
/// span a gap: the vertices of CAD models leave their flat faces unsampled
/// inside, so a faithful mesh of them is up to about the refinement distance
/// from the nearest point (gear at 500 clusters: 0.9 % of the diagonal, its
/// slots' faces 2.2 %).
pub(super) const GAP_SPAN: f32 = 2.0;

/// The share of the points within two k-NN steps of a rim point that must lie
/// ahead of it for the data to go on there. Measured at the rims the faces
/// offered, at 12 neighbours: at most 0.32 around the holes in the bunny's
/// base (28 rim points), at least 0.43 at the gear's slots (13).
const GOES_ON: f32 = 0.37;

/// How far off the rim point's tangent plane the face's sample must lie, as a
/// fraction of their distance. A face over a void in the sampling of the
/// surface it lies on (random samples leave empty disks up to about twice
/// their spacing wide) has its sample about in that plane: on a cylinder of
/// 5,000 random points at 120 clusters, 90 % of such faces are under 0.3
/// (the largest 0.66, cutting a sharp edge). A face across a tunnel or slot
/// faces the wall: the gear's hub holes at 250 clusters, 0.63 and more
/// (median 0.95).
const OFF_TANGENT: f32 = 0.5;

/// Barycentric weights of a face's samples.
const SAMPLES: [[f32; 3]; 7] = [
    [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0],
    [2.0 / 3.0, 1.0 / 6.0, 1.0 / 6.0],
    [1.0 / 6.0, 2.0 / 3.0, 1.0 / 6.0],
    [1.0 / 6.0, 1.0 / 6.0, 2.0 / 3.0],
    [0.5, 0.5, 0.0],
    [0.0, 0.5, 0.5],
    [0.5, 0.0, 0.5],
];

/// Steps of one walk at most (a bound on the work, never reached on a
/// surface: a walk crosses a cluster or two).
const STEPS: usize = 256;

/// The point the greedy walk from `start` towards `q` ends at, and its squared
/// distance to `q`.
fn descend(points: &[V3], nb: &Neighbours, start: u32, q: V3) -> Option<(f32, u32)> {
    let mut at = start;
    let mut best = dist2(*points.get(at as usize)?, q);
    for _ in 0..STEPS {
        let mut next = at;
        // Row by row rather than `symmetric`'s chained iterator: the same
        // neighbours in the same order, in fewer instructions.
        for row in nb.rows(at as usize) {
            for &j in row {
                if let Some(&p) = points.get(j as usize) {
                    let e = dist2(p, q);
                    if e < best || (e == best && j < next) {
                        best = e;
                        next = j;
                    }
                }
            }
        }
        if next == at {
            break;
        }
        at = next;
    }
    Some((best, at))
}

/// What [`faces_over_gaps`] needs besides the faces.
pub(super) struct GapSearch<'a> {
    /// The points.
    pub points: &'a [V3],
    /// Their k-NN graph.
    pub nb: &'a Neighbours<'a>,
    /// Their tangent planes.
    pub planes: &'a Planes<'a>,
    /// The points of each cluster.
    pub members: &'a Members<'a>,
    /// The mesh's vertices.
    pub vertices: &'a [V3],
    /// The cluster of each vertex.
    pub vertex_cluster: &'a [u32],
}

/// For every face farther than `bound` from the data at some sample, where
/// the data goes on past the rim there, the point its farthest sample's walk
/// ended at is offered to `offer` with that distance and the cluster whose
/// walk found it (faces in order; the caller keeps what it wants). The faces
/// are searched in parallel tasks, `found` holding one entry per face
/// (scratch, at least as long as `triangles`); the offers come after, in
/// face order, so they do not depend on the threads.
pub(super) fn faces_over_gaps(
    search: &GapSearch,
    triangles: &[[u32; 3]],
    bound: f32,
    found: &mut [Option<(u32, f32, u32)>],
    hooks: &dyn Progress,
    mut offer: impl FnMut(u32, f32, u32),
) {
    let n = triangles.len().min(found.len());
    let found = &mut found[..n];
    parallel::rows(hooks, found, 1, |items, rows| {
        for (f, row) in items.zip(rows.iter_mut()) {
            *row = face_over_gap(search, &triangles[f], bound);
        }
    });
    for &(cl, e, p) in found.iter().flatten() {
        offer(cl, e, p);
    }
}

/// [`faces_over_gaps`] for one face: the (cluster, distance, rim point) it
/// offers, if any.
fn face_over_gap(search: &GapSearch, t: &[u32; 3], bound: f32) -> Option<(u32, f32, u32)> {
    let GapSearch {
        points,
        nb,
        planes,
        members,
        vertices,
        vertex_cluster,
    } = *search;
    let bound2 = bound * bound;
    let (Some(&a), Some(&b), Some(&c)) = (
        vertices.get(t[0] as usize),
        vertices.get(t[1] as usize),
        vertices.get(t[2] as usize),
    ) else {
        return None;
    };
    // (squared distance, end point, cluster walked from, sample)
    let mut worst: Option<(f32, u32, u32, V3)> = None;
    // The nearest point of the last sample, where the next walk starts.
    let mut last: Option<(f32, u32, u32)> = None;
    for w in SAMPLES {
        let q = [0, 1, 2].map(|i| w[0] * a[i] + w[1] * b[i] + w[2] * c[i]);
        // The nearest of the walks from the last sample's nearest point
        // and from a point of the cluster of each corner with the most
        // weight in the sample (all three at the centroid).
        let heaviest = w[0].max(w[1]).max(w[2]);
        let from_last = last.and_then(|(_, p, cl)| {
            let (e, p) = descend(points, nb, p, q)?;
            Some((e, p, cl))
        });
        let near = t
            .iter()
            .zip(w)
            .filter(|&(_, x)| x == heaviest)
            .filter_map(|(&v, _)| vertex_cluster.get(v as usize))
            .filter(|&&cl| (cl as usize) < members.len())
            .filter_map(|&cl| {
                let first = *members.of(cl as usize).first()?;
                let (e, p) = descend(points, nb, first, q)?;
                Some((e, p, cl))
            })
            .chain(from_last)
            .fold(None, |m: Option<(f32, u32, u32)>, x| match m {
                Some(y) if y.0 <= x.0 => m,
                _ => Some(x),
            });
        last = near;
        if let Some((e, p, cl)) = near {
            if e > bound2 && worst.is_none_or(|y| e > y.0) {
                worst = Some((e, p, cl, q));
            }
        }
    }
    let (e, p, cl, q) = worst?;
    (off_tangent(points, planes, p, q) && goes_on(points, nb, planes, p, q))
        .then(|| (cl, libm::sqrtf(e), p))
}

/// Whether sample `q` lies off the tangent plane of rim point `p` by at least
/// [`OFF_TANGENT`] of their distance (a point without a usable plane: yes).
fn off_tangent(points: &[V3], planes: &Planes, p: u32, q: V3) -> bool {
    let (Some(&x), Some(u)) = (points.get(p as usize), planes.planes.get(p as usize)) else {
        return false;
    };
    let n = [u[0], u[1], u[2]];
    let d = sub(q, x);
    let (h, nn, dd) = (dot(d, n), dot(n, n), dot(d, d));
    if !(nn > 0.0 && nn.is_finite()) {
        return true;
    }
    h * h >= OFF_TANGENT * OFF_TANGENT * nn * dd
}

/// Whether the data goes on past rim point `p` towards sample `q`: at least
/// [`GOES_ON`] of the points within two k-NN steps of `p` (counted with
/// repeats) lie ahead of it, towards `q` in its tangent plane. At the rim of
/// a hole in the data, `q` lies about in `p`'s tangent plane and the data
/// ends there: few points lie ahead. Across a slot or a tunnel, the data goes
/// on (into the tunnel's wall), or `q` faces `p` from off its tangent plane,
/// where the short direction left in the plane splits the points about in
/// half (and one that is none at all counts as going on).
fn goes_on(points: &[V3], nb: &Neighbours, planes: &Planes, p: u32, q: V3) -> bool {
    let (Some(&x), Some(u)) = (points.get(p as usize), planes.planes.get(p as usize)) else {
        return false;
    };
    let n = [u[0], u[1], u[2]];
    let l = norm(n);
    if !(l > 0.0 && l.is_finite()) {
        return false;
    }
    let n = [n[0] / l, n[1] / l, n[2] / l];
    let d = sub(q, x);
    let h = dot(d, n);
    let dir = [d[0] - h * n[0], d[1] - h * n[1], d[2] - h * n[2]];
    if dot(dir, dir) == 0.0 {
        return true;
    }
    let (mut ahead, mut all) = (0usize, 0usize);
    for &a in nb.of(p as usize) {
        for b in core::iter::once(a).chain(nb.of(a as usize).iter().copied()) {
            if b == p {
                continue;
            }
            if let Some(&y) = points.get(b as usize) {
                all += 1;
                ahead += usize::from(dot(sub(y, x), dir) > 0.0);
            }
        }
    }
    ahead as f32 >= GOES_ON * all as f32
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::arena::Arena;
    use crate::clustering::knn::try_neighbours_in;
    use crate::clustering::quadric::try_planes_in;
    use crate::progress::Silent;
    use core::mem::MaybeUninit;
    use std::vec;
    use std::vec::Vec;

    /// A 1 x 1 plate at height `z`, spacing 0.05, without the points `skip` names.
    fn plate(z: f32, skip: impl Fn(f32, f32) -> bool) -> Vec<V3> {
        let mut p = Vec::new();
        for i in 0..21 {
            for j in 0..21 {
                let (x, y) = (i as f32 * 0.05, j as f32 * 0.05);
                if !skip(x, y) {
                    p.push([x, y, z]);
                }
            }
        }
        p
    }

    /// The points `faces_over_gaps` offers for one face whose corners are
    /// clusters of one point each: the points nearest the corners.
    fn offered(points: &[V3], face: [V3; 3], bound: f32) -> Vec<u32> {
        let mut buf = vec![MaybeUninit::uninit(); 8 * 1024 * 1024];
        let arena = Arena::new(&mut buf);
        let nb = try_neighbours_in(&arena, points, 12, &mut Silent).unwrap();
        let planes = try_planes_in(&arena, points, None, &nb, &mut Silent).unwrap();
        let nearest = |v: V3| {
            (0..points.len() as u32).min_by(|&a, &b| {
                dist2(points[a as usize], v).total_cmp(&dist2(points[b as usize], v))
            })
        };
        let list: Vec<u32> = face.iter().map(|&v| nearest(v).unwrap()).collect();
        let members = Members {
            start: &[0, 1, 2, 3],
            list: &list,
        };
        let search = GapSearch {
            points,
            nb: &nb,
            planes: &planes,
            members: &members,
            vertices: &face,
            vertex_cluster: &[0, 1, 2],
        };
        let mut out = Vec::new();
        faces_over_gaps(
            &search,
            &[[0, 1, 2]],
            bound,
            &mut [None],
            &Silent,
            |_, _, p| out.push(p),
        );
        out
    }

    #[test]
    fn a_face_across_the_gap_between_two_sheets_offers_a_rim_point() {
        // Two plates 0.3 apart (the walls of a slot); a face from one to the
        // other is 0.1 from both at its centroid.
        let mut points = plate(0.0, |_, _| false);
        points.extend(plate(0.3, |_, _| false));
        let face = [[0.5, 0.5, 0.0], [0.55, 0.5, 0.3], [0.5, 0.55, 0.3]];
        let got = offered(&points, face, 0.06);
        assert_eq!(got.len(), 1, "{got:?}");
        // Nothing beyond the largest distance of a sample.
        assert!(offered(&points, face, 0.16).is_empty());
    }

    #[test]
    fn a_face_over_a_hole_in_the_data_or_on_the_data_offers_nothing() {
        // A plate with a round hole of radius 0.2: the face over it is as far
        // from the data as the one across the sheets, but the data ends at
        // the rim.
        let hole = |x: f32, y: f32| (x - 0.5) * (x - 0.5) + (y - 0.5) * (y - 0.5) < 0.04;
        let points = plate(0.0, hole);
        let face = [[0.25, 0.5, 0.0], [0.75, 0.4, 0.0], [0.75, 0.6, 0.0]];
        let far = |q: V3| {
            points
                .iter()
                .map(|&p| dist2(p, q))
                .fold(f32::INFINITY, f32::min)
                .sqrt()
        };
        assert!(far([0.6, 0.5, 0.0]) > 0.1, "the face spans the hole");
        assert!(offered(&points, face, 0.06).is_empty());
        // The same face on a plate without the hole is near the data.
        let whole = plate(0.0, |_, _| false);
        assert!(offered(&whole, face, 0.06).is_empty());
    }

    #[test]
    fn a_face_over_a_void_in_the_sampling_offers_nothing() {
        // A void of radius 0.12 (the data goes on all around it, as in a
        // random sampling) under a face that lies in the plate: its samples
        // are far from the data, but in the rim's tangent plane.
        let void = |x: f32, y: f32| (x - 0.5) * (x - 0.5) + (y - 0.5) * (y - 0.5) < 0.0144;
        let points = plate(0.0, void);
        let face = [[0.4, 0.45, 0.0], [0.6, 0.45, 0.0], [0.5, 0.6, 0.0]];
        assert!(offered(&points, face, 0.06).is_empty());
    }
}
