//! Pre-passes: optional work on the cloud before reconstruction, each a separate
//! call whose result the caller applies before [`reconstruct`](crate::reconstruct).
//!
//! 0. [`mark_duplicates`](duplicates::mark_duplicates): marks the first of
//!    each set of exact duplicates (bitwise-equal positions), in `O(n log n)`
//!    and no memory but the caller's; the caller compacts them before
//!    anything searches neighbours.
//! 1. [`clean`](clean::clean): marks statistical outliers and small isolated
//!    fragments for removal; the caller compacts the kept points.
//! 2. [`smooth`](smooth::smooth): moves every point onto the least-squares plane
//!    of its neighbours, for noise near the point spacing.
//!
//! None leaves anything in the arena, so the same buffer serves the reconstruction.

pub mod clean;
pub mod duplicates;
pub mod smooth;
