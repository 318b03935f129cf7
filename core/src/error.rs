//! The crate's one error type: every failure is a value with the numbers a caller
//! needs to act on it.

use core::fmt;

pub use crate::arena::Exhausted;

/// What makes an input unable to form a surface.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Degeneracy {
    /// Every point is the same point.
    Coincident,
    /// Every point lies on one line.
    Collinear,
    /// Every point lies on one plane.
    Coplanar,
}

/// Parameters under which [`crate::reconstruct`] cannot make a mesh of any
/// cloud ([`crate::Params::meshable`]): refused before any work.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Unmeshable {
    /// Fewer clusters than the corners of a tetrahedron, the least closed
    /// surface: the mesh's vertices are the clusters' generators.
    TooFewClusters {
        /// `Params::clusters`.
        clusters: u32,
    },
    /// Both weights of the facet score are 0: every facet scores 0, and none
    /// is ever selected.
    NoScore,
    /// The support distance is below the precision of `f32` coordinates in
    /// `[-1, 1]` ([`crate::params::MIN_EPSILON`]): no point can be told to
    /// lie within it of a facet, so no facet has support.
    EpsilonBelowPrecision {
        /// `Params::epsilon`.
        epsilon: f32,
    },
}

impl fmt::Display for Unmeshable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Unmeshable::TooFewClusters { clusters } => write!(
                f,
                "{clusters} clusters cannot enclose a volume: a mesh needs at least {}",
                crate::params::MIN_MESH_CLUSTERS
            ),
            Unmeshable::NoScore => f.write_str(
                "the fitting and coverage weights are both 0: every facet scores 0 and none is selected",
            ),
            Unmeshable::EpsilonBelowPrecision { epsilon } => write!(
                f,
                "epsilon {epsilon:e} is below {:e}, the precision of the coordinates: no point can \
                 be told to lie within it of a facet",
                crate::params::MIN_EPSILON
            ),
        }
    }
}

/// Why a run failed.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Error {
    /// The arena ran out of memory.
    Exhausted(Exhausted),
    /// Fewer points than a surface needs.
    TooFewPoints {
        /// Points given.
        found: usize,
        /// Points required.
        needed: usize,
    },
    /// A coordinate (or given normal component) is NaN or infinite.
    NonFinite {
        /// Index of the point.
        index: usize,
        /// 0, 1, 2 for x, y, z.
        axis: u8,
        /// The offending value.
        value: f32,
        /// Whether it is a normal component rather than a coordinate.
        normal: bool,
    },
    /// The points cannot span a surface.
    Degenerate(Degeneracy),
    /// `k` is outside `1..=MAX_K` or not smaller than the number of points.
    BadNeighbours {
        /// The requested k.
        k: usize,
        /// Points given.
        points: usize,
    },
    /// A k-NN table given to core ([`crate::reconstruct_with_rows`]) is not one
    /// for these points: the wrong length (`row` is then the rows it holds and
    /// `entry` its length), or an entry out of range or equal to its row.
    BadNeighbourTable {
        /// The row at fault.
        row: usize,
        /// The entry at fault.
        entry: u64,
    },
    /// A parameter is outside its documented range.
    BadParameter {
        /// Field of `Params`.
        name: &'static str,
        /// The offending value.
        value: f32,
    },
    /// The normals slice does not match the points.
    NormalsLength {
        /// Points given.
        points: usize,
        /// Normals given.
        normals: usize,
    },
    /// More points than the `u32` indices of core can address.
    TooManyPoints {
        /// Points given.
        found: usize,
        /// The limit.
        max: usize,
    },
    /// The progress callback asked to stop.
    Cancelled,
    /// A meshing round needed more working memory than its capacity
    /// (`Params::mesh_bytes_per_cluster`): the candidate graph is denser than
    /// that capacity allows, typically because there are few points per cluster.
    /// The arena itself may have had room: the capacity is what keeps
    /// [`crate::arena_bytes`] an upper bound.
    MeshCapacity {
        /// The round's capacity in bytes.
        capacity: usize,
        /// Bytes of the request that did not fit.
        requested: usize,
        /// Bytes of the capacity still free at that moment.
        available: usize,
    },
    /// The arena is smaller than this run needs (checked before any work
    /// against the least any cloud of this size needs, then against what this
    /// cloud's neighbour graph needs as soon as it is counted:
    /// [`crate::reconstruct_bytes_for`]). Nothing was computed past that point.
    ArenaTooSmall {
        /// Bytes of buffer that are enough (alignment slack included).
        needed: usize,
        /// Usable bytes of the arena given.
        capacity: usize,
        /// Reverse-only neighbour edges of the cloud, when counted (`None`:
        /// the check before any work).
        reverse_edges: Option<usize>,
    },
    /// A meshing round ran out of an arena smaller than [`crate::arena_bytes`]
    /// (though as large as [`crate::reconstruct_bytes_for`]): its candidate
    /// graph needed more than the meshing capacity, which it may do only in
    /// room the worst-case budget leaves. A buffer of `needed` bytes gives the
    /// mesh.
    ArenaTooSmallForMeshing {
        /// Bytes of buffer that are enough: [`crate::arena_bytes`].
        needed: usize,
        /// Usable bytes of the arena given.
        capacity: usize,
    },
    /// [`crate::reconstruct`] was asked to mesh under parameters that cannot
    /// give a mesh; nothing was computed.
    Unmeshable(Unmeshable),
    /// The `keep` slice given to [`crate::clean()`] does not match the points.
    KeepLength {
        /// Points given.
        points: usize,
        /// Length of `keep`.
        keep: usize,
    },
    /// Cleaning ([`crate::clean()`]) would leave fewer points than a surface
    /// needs.
    TooFewKept {
        /// Points given.
        points: usize,
        /// Points cleaning would keep.
        kept: usize,
        /// Points required (at least 4, and more than `k`).
        needed: usize,
        /// Points removed as outliers.
        outliers: usize,
        /// Points removed in small fragments.
        fragment_points: usize,
    },
}

/// Result alias used across core.
pub type Result<T> = core::result::Result<T, Error>;

impl From<Exhausted> for Error {
    fn from(e: Exhausted) -> Self {
        Error::Exhausted(e)
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Error::Exhausted(e) => e.fmt(f),
            Error::TooFewPoints { found, needed } => {
                write!(f, "{found} points given; a surface needs at least {needed}")
            }
            Error::NonFinite {
                index,
                axis,
                value,
                normal,
            } => {
                let what = if normal { "normal" } else { "coordinate" };
                let axis = ["x", "y", "z"].get(axis as usize).copied().unwrap_or("?");
                write!(f, "point {index}: {what} {axis} is {value}, not a finite number")
            }
            Error::Degenerate(d) => {
                let what = match d {
                    Degeneracy::Coincident => "all points coincide",
                    Degeneracy::Collinear => "all points lie on one line",
                    Degeneracy::Coplanar => "all points lie on one plane",
                };
                write!(f, "{what}: no surface can be reconstructed")
            }
            Error::BadNeighbours { k, points } => write!(
                f,
                "k = {k} neighbours is not possible with {points} points (need 1 <= k <= {} and k < points)",
                crate::params::MAX_K
            ),
            Error::BadNeighbourTable { row, entry } => write!(
                f,
                "the neighbour table given is not one for these points (row {row}, entry {entry})"
            ),
            Error::BadParameter { name, value } => write!(f, "parameter {name} = {value} is out of range"),
            Error::Unmeshable(u) => write!(f, "no mesh can be made: {u}"),
            Error::NormalsLength { points, normals } => {
                write!(f, "{normals} normals given for {points} points")
            }
            Error::TooManyPoints { found, max } => {
                write!(f, "{found} points given; at most {max} are supported")
            }
            Error::Cancelled => f.write_str("cancelled"),
            Error::MeshCapacity {
                capacity,
                requested,
                available,
            } => write!(
                f,
                "meshing needs more than its {capacity} bytes of working memory \
                 ({requested} more requested, {available} left): the candidate graph is too \
                 dense, typically from too few points per cluster; use fewer clusters or \
                 raise the meshing memory per cluster"
            ),
            Error::ArenaTooSmall {
                needed,
                capacity,
                reverse_edges: None,
            } => write!(
                f,
                "the arena has {capacity} bytes; a run on this many points with these \
                 parameters needs at least {needed}"
            ),
            Error::ArenaTooSmall {
                needed,
                capacity,
                reverse_edges: Some(r),
            } => write!(
                f,
                "the arena has {capacity} bytes; this cloud needs {needed} (its neighbour \
                 graph has {r} one-way edges)"
            ),
            Error::ArenaTooSmallForMeshing { needed, capacity } => write!(
                f,
                "the arena has {capacity} bytes; meshing this cloud took more than its \
                 capacity (a dense candidate graph: few points per cluster), which only a \
                 buffer of {needed} bytes always has room for"
            ),
            Error::KeepLength { points, keep } => {
                write!(f, "keep has {keep} entries for {points} points")
            }
            Error::TooFewKept {
                points,
                kept,
                needed,
                outliers,
                fragment_points,
            } => write!(
                f,
                "cleaning would remove {} of {points} points ({outliers} outliers, \
                 {fragment_points} in small fragments), leaving {kept}; a surface needs at \
                 least {needed}: lower the outlier filter or the fragment size",
                points - kept.min(points)
            ),
        }
    }
}
