//! The std front end of vsaqem: file formats, normalisation, arena sizing, reports.
//! No algorithm lives here; see `vsaqem-core`.

pub mod args;
pub mod attributes;
pub mod clean;
pub mod cli;
pub mod cmd;
pub mod eval;
pub mod geom;
pub mod input;
pub mod io;
pub mod limits;
pub mod normalize;
pub mod outputs;
pub mod progress;
pub mod render;
pub mod report;
pub mod stdout;
pub mod team;
