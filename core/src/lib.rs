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

pub mod arena;
pub mod error;
pub mod math;
pub mod params;
pub mod progress;

pub use arena::{Arena, Exhausted, Scratch};
pub use error::{Degeneracy, Error, Result};
pub use params::{Params, MAX_K};
pub use progress::{Flow, Progress, Silent, Stage};
