//! The coordinate contract with core: [`vsaqem_core::Frame`] (centre and
//! scale into `[-1, 1]^3` in `f64`, results mapped back the same way).

pub use vsaqem_core::Frame;
