//! The clustering half of VSA-QEM: from points to clusters with QEM-optimal
//! generators, one file per stage in the order data flows.
//!
//! 1. [`knn`]: a sparse uniform grid and the certified k nearest neighbours of
//!    every point, with the graph's reverse links.
//! 2. [`normals`]: the caller's normals where usable, else PCA of each
//!    neighbourhood.
//! 3. [`quadric`]: area-weighted plane quadrics of the points (seed Eq. 1-2) and
//!    their diffusion over each neighbourhood (Eq. 3).
//! 4. [`partition`]: seeded initialisation, region-growing partition (Eq. 4) and
//!    QEM-optimal generator updates (Eq. 5), alternated with
//! 5. [`split`]: batch splitting of the clusters whose error exceeds the
//!    tolerance (Eq. 6).
//!
//! [`cluster`](crate::cluster()) and [`reconstruct`](crate::reconstruct) run the
//! stages in that order.

pub mod knn;
pub mod normals;
pub mod partition;
pub mod quadric;
mod slabs;
pub mod split;
pub(crate) mod sweep;

use crate::arena::Arena;
use crate::error::{Error, Result};
use crate::math::V3;
use crate::params::Params;
use crate::progress::{tick, Progress, Stage};
use crate::validate::{self, Bounds};
use crate::Rows;
use knn::Neighbours;
use partition::{ClusterState, ClusterStats, Clusters};
use quadric::Planes;

/// Statistics of a run, per stage.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Stats {
    /// Input points.
    pub points: u32,
    /// Neighbours per point.
    pub k: u32,
    /// Average spacing (mean distance to the k nearest neighbours).
    pub spacing: f32,
    /// Points whose neighbour query fell back to a linear scan.
    pub linear_scans: u32,
    /// Reverse-only edges of the symmetrised neighbour graph.
    pub reverse_edges: u32,
    /// Clustering statistics.
    pub cluster: ClusterStats,
    /// Arena peak in bytes after the neighbour stage.
    pub peak_neighbours: usize,
    /// Arena peak in bytes after the quadric stage.
    pub peak_quadrics: usize,
    /// Arena peak in bytes after clustering.
    pub peak_clustering: usize,
}

/// Everything clustering produced, borrowed from the arena.
pub struct Clustered<'a> {
    /// Bounding box of the input.
    pub bounds: Bounds,
    /// The k-NN graph and its symmetrisation.
    pub neighbours: Neighbours<'a>,
    /// Area-weighted plane quadrics.
    pub planes: Planes<'a>,
    /// Labels and generators.
    pub clusters: Clusters<'a>,
    /// Statistics.
    pub stats: Stats,
}

/// Clustering while its clusters can still grow (refinement adds generators
/// where a mesh leaves data uncovered): the fixed results of stages 1-3 and the
/// open state of stages 4-5.
pub(crate) struct Clustering<'a> {
    /// Bounding box of the input.
    pub bounds: Bounds,
    /// The k-NN graph and its symmetrisation.
    pub neighbours: Neighbours<'a>,
    /// Area-weighted plane quadrics.
    pub planes: Planes<'a>,
    /// Labels and generators, still open to refinement.
    pub state: ClusterState<'a>,
    /// Statistics of stages 1-3 (the clustering's own are in `state`).
    stats: Stats,
}

impl<'a> Clustering<'a> {
    /// The clusters made final, for the arena's lifetime.
    pub fn close(self, arena: &Arena) -> Clustered<'a> {
        let clusters = self.state.freeze();
        let stats = Stats {
            cluster: clusters.stats,
            peak_clustering: self.stats.peak_clustering.max(arena.peak()),
            ..self.stats
        };
        Clustered {
            bounds: self.bounds,
            neighbours: self.neighbours,
            planes: self.planes,
            clusters,
            stats,
        }
    }
}

/// What a run needs from the arena's position at its start, in bytes (a
/// multiple of the granule): `(points, params, reverse-only edges, searched)`,
/// as [`crate::budget`] bounds it for the whole run.
pub(crate) type Need = fn(usize, &Params, usize, bool) -> usize;

/// Checks the input, then runs stages 1-5 in `arena` (stage 1 from `known`
/// rows when given: borrowed, not searched again). `need` is what the whole
/// run takes from the arena's position at the start: checked against the
/// arena's capacity before any work (with no reverse-only edges, the least
/// any cloud needs) and again once the neighbour graph's reverse-only edges
/// are counted, before their table is allocated; either check failing is
/// [`Error::ArenaTooSmall`].
///
/// Never inlined: inlined into [`crate::reconstruct_with_rows`], its locals
/// would sit under every meshing round (the firmware's stack mark rose by
/// 4,376 bytes when a smaller quadrics stage let LLVM inline it).
#[inline(never)]
pub(crate) fn try_clustering_in<'a>(
    arena: &'a Arena,
    points: &[V3],
    normals: Option<&[V3]>,
    known: Option<&Rows<'a>>,
    params: &Params,
    need: Need,
    progress: &mut dyn Progress,
) -> Result<Clustering<'a>> {
    tick(progress, Stage::Validate, 0, 1)?;
    let bounds = validate::check(points, normals, params)?;
    tick(progress, Stage::Validate, 1, 1)?;
    let (n, searched, start) = (points.len(), known.is_none(), arena.used());
    let fits = |reverse_edges: Option<usize>| -> Result<()> {
        let bytes = need(n, params, reverse_edges.unwrap_or(0), searched);
        let end = start.saturating_add(bytes);
        if end > arena.capacity() {
            return Err(Error::ArenaTooSmall {
                needed: crate::budget::buffer_for(end),
                capacity: arena.capacity(),
                reverse_edges,
            });
        }
        Ok(())
    };
    fits(None)?;
    let room = |reverse_edges: usize| fits(Some(reverse_edges));
    let neighbours = match known {
        Some(r) => knn::try_neighbours_from_in(
            arena,
            points,
            r.knn,
            params.k,
            r.linear_scans,
            &room,
            progress,
        )?,
        None => knn::try_neighbours_checked_in(arena, points, params.k, &room, progress)?,
    };

    let peak_neighbours = arena.peak();
    let planes = quadric::try_planes_in(arena, points, normals, &neighbours, progress)?;
    let peak_quadrics = arena.peak();
    let state = partition::try_cluster_state_in(
        arena,
        points,
        &neighbours,
        &planes,
        bounds.diag,
        params,
        progress,
    )?;
    let stats = Stats {
        points: points.len() as u32,
        k: params.k as u32,
        spacing: neighbours.spacing,
        linear_scans: neighbours.linear_scans,
        reverse_edges: neighbours.rev.len() as u32,
        cluster: state.stats,
        peak_neighbours,
        peak_quadrics,
        peak_clustering: arena.peak(),
    };
    Ok(Clustering {
        bounds,
        neighbours,
        planes,
        state,
        stats,
    })
}
