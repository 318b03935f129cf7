//! How much arena a run needs: [`arena_bytes`] for [`reconstruct`](crate::reconstruct),
//! [`cluster_bytes`] for [`cluster`](crate::cluster()), [`clean_bytes`] for
//! [`clean`](crate::clean()).
//!
//! All three are upper bounds, never estimates: a run on `n` points with the same
//! [`Params`] never fails with [`Error::Exhausted`](crate::Error::Exhausted) in an
//! arena of that size (tested on every shared cloud and generated shapes, down to
//! the byte: `arena-tests/tests/memory_budget.rs`, `clean.rs`). The bound is the largest, over
//! the stages, of what is live while the stage runs, each allocation counted at
//! its worst alignment padding ([`padded_bytes`]):
//!
//! | stage | live at its peak | bytes per point (k = 12) |
//! |---|---|---|
//! | neighbours | k-NN table + the larger of the grid scratch and the reverse table being built | 48 + 92 |
//! | quadrics | k-NN + reverse table (worst case: no mutual neighbours) + planes + their scratch (each point's weight, then a byte per point the noise floor samples, 8,191 at most) | 48 + 52 + 16 + 4 (+ 1) |
//! | clustering | the above + labels + the largest scratch step (a partition) | 116 + 4 + 16 |
//! | meshing | the above (without scratch) + the meshing capacity | 120 + 4 + per cluster |
//!
//! Plus 32 bytes per cluster of the limit (generators, seeds, their backups)
//! and 4 for the refinement list. The limit is what splitting and refinement
//! may reach ([`Params::cluster_limit`]): the cap, `max_clusters` (twice
//! `clusters` by default), and a thirty-second more for refinement at the rims of
//! gaps; or the number of connected components of the neighbour graph when
//! larger (at most `n / (k + 1)`: every point has its k neighbours in its
//! component).
//!
//! [`clean_bytes`] bounds the cleaning pre-pass [`clean`](crate::clean()) in the
//! same way: the k-NN table plus the larger of the grid's scratch and the
//! filters' three per-point arrays (4 + 4 + 4 bytes), never more than the
//! neighbour stage of `reconstruct`, so a buffer of [`arena_bytes`] serves
//! both, one after the other.
//!
//! What a run really uses is less, and depends on the data: the reverse table is
//! one or two entries per point on real scans rather than `k`, the grid a third of
//! its bound, and the candidate graph of meshing is as dense as the clusters make
//! it. Its size is not a function of `n` and the parameters at all (3 candidate
//! facets per cluster on a well-sampled surface, more than 10 with three points
//! per cluster), so meshing runs under a ceiling of its own,
//! [`mesh_capacity`]: `4 n + Params::mesh_bytes_per_cluster × limit` bytes per
//! round. A denser candidate graph fails with
//! [`Error::MeshCapacity`](crate::Error::MeshCapacity), whatever the arena's size,
//! so the output never depends on how much memory the caller happened to give.
//!
//! A smaller buffer may still do: [`reconstruct_bytes_for`] and
//! [`cluster_bytes_for`] are the same bounds with the reverse table at the
//! size a cloud's neighbour graph really has (and without the k-NN table and
//! its search's scratch when the caller gives the table). A run checks its
//! buffer against them twice, failing with
//! [`Error::ArenaTooSmall`](crate::Error::ArenaTooSmall) before it computes
//! anything more: before any work with no reverse edge (the least for `n`
//! points), and once the reverse edges are counted, before their table is
//! allocated. Meshing's ceiling stays the worst-case bound, so a buffer that
//! passes gives the same result, or, where meshing needed more than its
//! capacity, [`Error::ArenaTooSmallForMeshing`](crate::Error::ArenaTooSmallForMeshing).

use crate::arena::{padded_bytes, GRANULE};
use crate::clustering::{knn, partition, quadric};
use crate::params::{Params, MAX_K};

/// The most clusters a run on `n` points can hold: the limit of splitting and
/// refinement ([`Params::cluster_limit`]), or the components of the neighbour
/// graph when there are more (see the module docs).
fn cap_bound(n: usize, params: &Params) -> usize {
    let k = params.k.clamp(1, MAX_K);
    (params.cluster_limit() as usize)
        .min(n)
        .max(n / (k + 1))
        .max(1)
}

/// A buffer of `bound` usable bytes, whatever its alignment: the arena skips
/// up to 7 bytes to start on a granule boundary.
pub(crate) fn buffer_for(bound: usize) -> usize {
    bound.saturating_add(GRANULE - 1)
}

/// Arena bytes that are always enough for [`cluster`](crate::cluster()) on `n`
/// points with `params` (see the module docs).
pub fn cluster_bytes(n: usize, params: &Params) -> usize {
    let k = params.k.clamp(1, MAX_K);
    buffer_for(cluster_bound_for(n, params, n.saturating_mul(k), true))
}

/// Arena bytes that are always enough for [`clean`](crate::clean()) on `n` points: the k-NN
/// table (`4 k` per point) plus the larger of the grid's scratch
/// ([`knn::grid_scratch_bytes`]) and the three per-point arrays of the filters (12
/// per point), plus 7 for a buffer that does not start on an 8-byte boundary.
/// About 140 bytes per point at k = 12; never more than
/// [`arena_bytes`] for the same `n` and `params`.
pub fn clean_bytes(n: usize, params: &Params) -> usize {
    clean_bytes_for(n, params, false)
}

/// [`clean_bytes`] when the caller gives the k-NN table to fill
/// ([`clean_with_rows`](crate::clean_with_rows)): the table is then not in the
/// arena (about 92 bytes per point at k = 12).
pub fn clean_bytes_for(n: usize, params: &Params, table_given: bool) -> usize {
    let k = params.k.clamp(1, MAX_K);
    let rows = if table_given {
        0
    } else {
        padded_bytes::<u32>(n.saturating_mul(k))
    };
    let filters = padded_bytes::<f32>(n).saturating_add(padded_bytes::<u32>(n).saturating_mul(2));
    let bound = rows.saturating_add(knn::grid_scratch_bytes(n).max(filters));
    buffer_for(round_up(bound))
}

/// Arena bytes that are always enough for [`reconstruct`](crate::reconstruct) on
/// `n` points with `params`, refinement rounds included: the largest of the
/// stages' peaks (see the module docs), plus 7 bytes for a buffer that does not
/// start on an 8-byte boundary. About 140 bytes per point at k = 12 for large
/// clouds, plus `mesh_bytes_per_cluster` and some 70 bytes per cluster of the
/// cap. Saturates at `usize::MAX` instead of overflowing.
///
/// A smaller buffer may do: see [`reconstruct_bytes_for`], which is what a
/// run checks (and fails with [`Error::ArenaTooSmall`](crate::Error::ArenaTooSmall)
/// as soon as it knows it is short).
pub fn arena_bytes(n: usize, params: &Params) -> usize {
    buffer_for(reconstruct_bound(n, params))
}

/// What [`reconstruct`](crate::reconstruct) on `n` points needs once its
/// neighbour graph is known: as [`arena_bytes`], with the reverse-only table at
/// its real size (`reverse_edges` entries, where the worst case is `k n`) and,
/// when `searched` is false (the k-NN table was given,
/// [`reconstruct_with_rows`](crate::reconstruct_with_rows)), neither the k-NN
/// table nor the search's scratch. With `reverse_edges` = 0 it is the least any
/// cloud of `n` points needs, which a run checks before any work; with the
/// real count, checked as soon as it is counted (before the table is
/// allocated). A run in a buffer of at least this size gives the same result as
/// in one of [`arena_bytes`]: meshing's ceiling is this bound, whatever the
/// buffer (real scans have one or two reverse-only edges per point, so 1M
/// points need about 100 bytes each instead of 140).
pub fn reconstruct_bytes_for(
    n: usize,
    params: &Params,
    reverse_edges: usize,
    searched: bool,
) -> usize {
    buffer_for(reconstruct_bound_for(n, params, reverse_edges, searched))
}

/// The most [`reconstruct`](crate::reconstruct) uses (a multiple of the
/// granule) at the worst: every neighbour relation one-way, the table searched.
pub(crate) fn reconstruct_bound(n: usize, params: &Params) -> usize {
    let k = params.k.clamp(1, MAX_K);
    reconstruct_bound_for(n, params, n.saturating_mul(k), true)
}

/// The most [`reconstruct`](crate::reconstruct) uses (a multiple of the
/// granule) with `reverse_edges` reverse-only neighbour edges: meshing may fill
/// the arena up to here, never beyond.
pub(crate) fn reconstruct_bound_for(
    n: usize,
    params: &Params,
    reverse_edges: usize,
    searched: bool,
) -> usize {
    let (clustering, kept) = stages(n, params, reverse_edges, searched);
    let cap = cap_bound(n, params);
    // Refinement keeps one list of uncovered clusters, then runs a clustering
    // step (its scratch is within the clustering bound) on top of it.
    let list = padded_bytes::<u32>(cap);
    let refine = clustering.saturating_add(list);
    let meshing = kept
        .saturating_add(list)
        .saturating_add(mesh_capacity(n, cap, params));
    round_up(refine.max(meshing))
}

/// What [`cluster`](crate::cluster()) on `n` points needs once its neighbour
/// graph is known: [`cluster_bytes`] with the real reverse-only table and,
/// unless `searched`, no k-NN table nor search scratch (see
/// [`reconstruct_bytes_for`]).
pub fn cluster_bytes_for(n: usize, params: &Params, reverse_edges: usize, searched: bool) -> usize {
    buffer_for(cluster_bound_for(n, params, reverse_edges, searched))
}

/// [`cluster_bytes_for`] without the alignment slack (a multiple of the granule).
pub(crate) fn cluster_bound_for(
    n: usize,
    params: &Params,
    reverse_edges: usize,
    searched: bool,
) -> usize {
    round_up(stages(n, params, reverse_edges, searched).0)
}

fn round_up(bytes: usize) -> usize {
    bytes
        .checked_add(GRANULE - 1)
        .map_or(usize::MAX & !(GRANULE - 1), |b| b & !(GRANULE - 1))
}

/// Bytes a meshing round may use when clustering holds `cap` clusters at most
/// (see [`Params::mesh_bytes_per_cluster`]): 4 per point (member lists), 60 per
/// cluster (the per-cluster tables live at once: representatives, list starts,
/// pieces of the data, border flags and positions, 45 bytes; the rims of gaps
/// the faces span and a copy of the far points, 12), `mesh_bytes_per_cluster`
/// per cluster up to the limit the parameters ask for
/// ([`Params::cluster_limit`]), and 1 KiB (the granule rounding of some
/// seventy allocations). Clusters beyond the asked limit exist only when the neighbour graph has more
/// components than that, each component with a cluster of its own; they get
/// the 60 bytes, not the per-cluster capacity, so that the budget does not
/// assume every cloud is dust.
pub fn mesh_capacity(n: usize, cap: usize, params: &Params) -> usize {
    let asked = (params.cluster_limit() as usize).min(n).min(cap);
    n.saturating_mul(4)
        .saturating_add(cap.saturating_mul(60))
        .saturating_add(params.mesh_capacity_per_cluster().saturating_mul(asked))
        .saturating_add(1024)
}

/// `(peak of neighbours, quadrics and clustering, what clustering keeps)` with
/// `reverse_edges` reverse-only neighbour edges, the k-NN table in the arena
/// (and its search's scratch) when `searched`.
fn stages(n: usize, params: &Params, reverse_edges: usize, searched: bool) -> (usize, usize) {
    let [neighbours, quadrics, clustering, kept] = stage_peaks(n, params, reverse_edges, searched);
    (neighbours.max(quadrics).max(clustering), kept)
}

/// The peaks of the neighbour, quadrics and clustering stages of [`stages`],
/// and what clustering keeps.
fn stage_peaks(n: usize, params: &Params, reverse_edges: usize, searched: bool) -> [usize; 4] {
    let k = params.k.clamp(1, MAX_K);
    let (neighbours, nb_kept) = knn::neighbours_bytes_for(n, k, reverse_edges, searched);
    let planes = nb_kept.saturating_add(quadric::planes_bytes(n));
    let quadrics = planes.saturating_add(quadric::planes_scratch_bytes(n));
    let sweeps = params.partition.sweeps(n);
    let (cl_kept, cl_scratch) = partition::partition_bytes(n, cap_bound(n, params), sweeps);
    let kept = planes.saturating_add(cl_kept);
    let clustering = kept.saturating_add(cl_scratch);
    [neighbours, quadrics, clustering, kept]
}

/// Arena bytes that are always enough for one round of
/// [`smooth`](crate::prepass::smooth::smooth) on `n` points with `k` neighbours: the k-NN
/// rows, then the larger of the grid's scratch (while they are found) and the
/// copy of the points, plus 7 for a buffer that does not start on an 8-byte
/// boundary.
pub(crate) fn smooth_bound(n: usize, k: usize) -> usize {
    let rows = padded_bytes::<u32>(n.saturating_mul(k));
    let copy = padded_bytes::<crate::math::V3>(n);
    buffer_for(round_up(
        rows.saturating_add(knn::grid_scratch_bytes(n).max(copy)),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The quadrics stage's scratch (each point's weight, the noise floor's
    /// bins) never sets the bound: the clustering stage after it holds more,
    /// for every point count, neighbour count and reverse table tried.
    #[test]
    fn the_quadrics_stage_stays_below_the_clustering_stage() {
        let counts = (1..3000).chain([4095, 4096, 8191, 8192, 100_000, 1 << 20, 10_000_000]);
        for n in counts {
            for k in [1, 4, 12, MAX_K] {
                for clusters in [1, 1000] {
                    let params = Params {
                        k,
                        clusters,
                        ..Params::default()
                    };
                    for (reverse, searched) in [(0, true), (n * k, true), (0, false)] {
                        let [_, quadrics, clustering, _] =
                            stage_peaks(n, &params, reverse, searched);
                        assert!(
                            quadrics <= clustering,
                            "n {n}, k {k}, clusters {clusters}, reverse {reverse}: \
                             quadrics {quadrics} > clustering {clustering}"
                        );
                    }
                }
            }
        }
    }
}
