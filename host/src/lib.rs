//! The std front end of vsaqem: file formats, normalisation, arena sizing, reports.
//! No algorithm lives here; see `vsaqem-core`.

pub mod io;
