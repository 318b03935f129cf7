//! # vsaqem-core
//!
//! Variational Shape Reconstruction via Quadric Error Metrics (VSA-QEM) for point
//! clouds, in a fixed amount of memory that the caller supplies.
//!
//! `#![no_std]`, no `alloc`, no global allocator: every byte comes from an [`Arena`]
//! over a caller-owned buffer, and running out of it is an [`Error::Exhausted`]
//! value, never a panic. Core never panics on any input.
//!
//! ## Conventions
//! - Coordinates are `f32` and expected in `[-1, 1]^3`: the host centres and scales
//!   its `f64` input into that cube and maps results back. Core works on any finite
//!   input, but `f32` quadric solves lose precision far from the origin.
//! - Structure of arrays, `u32` indices (so at most `u32::MAX - 1` points).
//! - Reductions over many values (cluster quadrics, averages) accumulate in `f64`.
//! - Deterministic: the same input and [`Params`] give bit-identical results.
//!
//! ## The pipeline (see `../shared/DESIGN.md`, steps 1-7)
//! 1. [`knn`]: sparse uniform grid and certified k nearest neighbours.
//! 2. [`normals`]: given normals, or PCA of each neighbourhood.
//! 3. [`quadric`]: area-weighted plane quadrics; diffused quadrics (seed Eq. 1-3).
//! 4. [`cluster`]: seeded initialisation, region growing (Eq. 4), QEM-optimal
//!    generators (Eq. 5), with [`split`] (Eq. 6) between rounds.
#![no_std]
#![deny(unsafe_code)]
#![warn(missing_docs)]
#![allow(clippy::needless_range_loop)]

#[cfg(test)]
extern crate std;

pub mod arena;
pub mod cluster;
pub mod error;
pub mod knn;
pub mod math;
pub mod normals;
pub mod params;
pub mod progress;
pub mod quadric;
pub mod sample;
pub mod split;
pub mod validate;

pub use arena::{Arena, Exhausted, Scratch};
pub use cluster::{ClusterStats, Clusters};
pub use error::{Degeneracy, Error, Result};
pub use knn::Neighbours;
pub use math::V3;
pub use params::{Params, MAX_K};
pub use progress::{Flow, Progress, Silent, Stage};
pub use quadric::Planes;
pub use validate::Bounds;

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

/// The clustering half of VSA-QEM: neighbours, quadrics, partition and splitting.
///
/// `points` should lie in `[-1, 1]^3` (see the crate docs); `normals`, when given,
/// are used where finite and non-zero. Fails with a typed error on bad input or
/// when `arena` is too small; never panics.
pub fn cluster<'a>(
    arena: &'a Arena,
    points: &[V3],
    normals: Option<&[V3]>,
    params: &Params,
    progress: &mut dyn Progress,
) -> Result<Clustered<'a>> {
    progress::tick(progress, Stage::Validate, 0, 1)?;
    let bounds = validate::check(points, normals, params)?;
    progress::tick(progress, Stage::Validate, 1, 1)?;
    let neighbours = knn::try_neighbours_in(arena, points, params.k, progress)?;
    let peak_neighbours = arena.peak();
    let planes = quadric::try_planes_in(arena, points, normals, &neighbours, progress)?;
    let peak_quadrics = arena.peak();
    let clusters = cluster::try_cluster_in(
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
        cluster: clusters.stats,
        peak_neighbours,
        peak_quadrics,
        peak_clustering: arena.peak(),
    };
    Ok(Clustered {
        bounds,
        neighbours,
        planes,
        clusters,
        stats,
    })
}

/// Arena bytes that are always enough for [`cluster`] on `n` points with `params`:
/// the largest sum of live allocations over the stages, with the reverse-edge table
/// at its worst case (no mutual neighbours). See `../shared/DESIGN.md`, "Memory".
pub fn cluster_bytes(n: usize, params: &Params) -> usize {
    let k = params.k.clamp(1, MAX_K);
    let n = n.max(validate::MIN_POINTS);
    // Every component gets a generator, and a component has at least k + 1 points.
    let cap = (params.cluster_cap() as usize).max(n / (k + 1) + 1).min(n);
    let knn = 4 * k * n + 64;
    let rev = 4 * (n + 1) + 4 * k * n + 128;
    let neighbour_stage = knn + (knn::grid_scratch_bytes(n)).max(rev + 4 * n);
    let planes = 16 * n + 64;
    let cluster_stage = knn + rev + planes + cluster::cluster_bytes(n, cap);
    neighbour_stage.max(cluster_stage)
}
