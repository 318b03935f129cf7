//! Batch splitting (seed Eq. 6): add a generator at the worst point of every
//! cluster whose error exceeds the tolerance, at most one per neighbourhood.
//!
//! Error of a point `p` under generator `c`: `[c,1]ᵀ Q_v(p) [c,1] / W_p`, where
//! `W_p` is the total area weight of `p`'s diffused quadric. Every plane in `Q_v(p)`
//! has a unit normal, so this is the area-weighted *mean squared distance* from
//! `c` to the tangent planes of `p` and its neighbours: a squared length. The
//! user's tolerance `t` (relative to the bounding-box diagonal `D`) therefore maps
//! to the QEM threshold `(t D)² W_p` for point `p` — the conversion the seed paper
//! leaves implicit, made exact here.
//!
//! Candidates are visited by decreasing error; a cluster is split only if no
//! cluster adjacent to it (sharing a symmetrised k-NN edge) was split in this
//! batch — a greedy independent set, so one batch never over-refines one area.
//! Cost: O(n k) plus a sort of the candidates; memory: 8 bytes per point (point
//! errors, member lists) plus O(clusters), all scratch.

use crate::arena::{padded_bytes, Scratch};
use crate::clustering::partition::Ctx;
use crate::error::Result;
use crate::math::V3;
use crate::parallel;
use crate::progress::Progress;

/// Scratch bytes of one batch over at most `m` clusters: point errors and
/// member lists (8 per point) and 21 bytes per cluster. Keep in step with `try_split_in`.
pub fn split_bytes(n: usize, m: usize) -> usize {
    [
        padded_bytes::<u32>(m),                   // worst
        padded_bytes::<f32>(m),                   // worst_e
        padded_bytes::<u32>(m.saturating_add(1)), // start
        padded_bytes::<u32>(m),                   // cand
        padded_bytes::<u32>(n),                   // members
        padded_bytes::<u32>(m),                   // cursor
        padded_bytes::<bool>(m),                  // blocked
        padded_bytes::<f32>(n),                   // errors
    ]
    .iter()
    .fold(0usize, |a, &b| a.saturating_add(b))
}

/// Squared error of point `i` under generator `c` (see the module docs).
#[inline(always)]
pub(crate) fn point_error2(ctx: &Ctx, i: usize, c: V3) -> f32 {
    let w = ctx.planes.diffused_weight(ctx.nb, i);
    if w > 0.0 {
        ctx.planes.diffused_qem(ctx.nb, ctx.points[i], i, c) / w
    } else {
        0.0
    }
}

/// Largest squared point error over all clusters (parallel tasks over ranges
/// of points; a maximum does not depend on the order it is taken in).
pub(crate) fn max_error2(
    ctx: &Ctx,
    labels: &[u32],
    generators: &[V3],
    hooks: &dyn Progress,
) -> f32 {
    let worst = parallel::ranges(hooks, labels.len(), |items| {
        let mut worst = 0.0f32;
        for i in items {
            if let Some(&c) = generators.get(labels[i] as usize) {
                worst = worst.max(point_error2(ctx, i, c));
            }
        }
        worst
    });
    worst.iter().fold(0.0f32, |a, &b| a.max(b))
}

/// Run one batch over the first `m` clusters, appending at most `limit` new
/// generators (and their seed points) after them, never beyond `cap`. Returns how
/// many were added.
#[allow(clippy::too_many_arguments)]
pub(crate) fn try_split_in(
    s: &Scratch,
    ctx: &Ctx,
    labels: &[u32],
    generators: &mut [V3],
    seeds: &mut [u32],
    m: usize,
    cap: usize,
    tol2: f32,
    limit: usize,
    hooks: &dyn Progress,
) -> Result<usize> {
    let n = labels.len();
    let worst = s.try_alloc_slice::<u32>(m, u32::MAX)?;
    let worst_e = s.try_alloc_slice::<f32>(m, -1.0)?;
    let start = s.try_alloc_slice::<u32>(m + 1, 0)?;
    // The point errors in parallel; each cluster's worst (the first of
    // equals) in point order.
    let errors = s.try_alloc_slice::<f32>(n, 0.0)?;
    let g = &*generators;
    parallel::rows(hooks, errors, 1, |items, out: &mut [f32]| {
        for (i, e) in items.zip(out.iter_mut()) {
            if let Some(&c) = g[..m.min(g.len())].get(labels[i] as usize) {
                *e = point_error2(ctx, i, c);
            }
        }
    });
    for (i, &l) in labels.iter().enumerate() {
        let j = l as usize;
        if j >= m {
            continue;
        }
        start[j + 1] += 1;
        let e = errors[i];
        if e > worst_e[j] {
            worst_e[j] = e;
            worst[j] = i as u32;
        }
    }
    let room = cap.saturating_sub(m).min(limit);
    if room == 0 {
        return Ok(0);
    }
    let mut n_cand = 0;
    let cand = s.try_alloc_slice::<u32>(m, 0)?;
    for j in 0..m {
        let size = start[j + 1];
        if worst_e[j] > tol2 && size >= 2 && worst[j] != seeds[j] {
            cand[n_cand] = j as u32;
            n_cand += 1;
        }
    }
    let cand = &mut cand[..n_cand];
    cand.sort_unstable_by(|&a, &b| {
        worst_e[b as usize]
            .total_cmp(&worst_e[a as usize])
            .then(a.cmp(&b))
    });
    // Members of each cluster, contiguous (counting sort by label).
    for j in 0..m {
        start[j + 1] += start[j];
    }
    let members = s.try_alloc_slice::<u32>(n, 0)?;
    let cursor = s.try_alloc_copy::<u32>(&start[..m])?;
    for (i, &l) in labels.iter().enumerate() {
        let j = l as usize;
        if j < m {
            members[cursor[j] as usize] = i as u32;
            cursor[j] += 1;
        }
    }
    let blocked = s.try_alloc_slice::<bool>(m, false)?;
    let mut added = 0;
    for &j in cand.iter() {
        if added == room {
            break;
        }
        let j = j as usize;
        if blocked[j] {
            continue;
        }
        blocked[j] = true;
        for &p in &members[start[j] as usize..start[j + 1] as usize] {
            for &q in ctx.nb.rows(p as usize).iter().copied().flatten() {
                if let Some(b) = blocked.get_mut(labels[q as usize] as usize) {
                    *b = true;
                }
            }
        }
        let w = worst[j];
        generators[m + added] = ctx.points[w as usize];
        seeds[m + added] = w;
        added += 1;
    }
    Ok(added)
}
