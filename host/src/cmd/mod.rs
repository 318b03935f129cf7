//! The subcommands: each file holds one command's arguments (`Cmd`), its `run`, and
//! what only it uses.

pub mod cluster;
pub mod eval;
pub mod reconstruct;
pub mod render;
