//! What the fuzz targets share: reading structured values off the fuzzer's bytes,
//! and the byte layouts of the `eval` and `reconstruct` inputs (the seed writer,
//! `host/examples/fuzz_seeds.rs`, writes the same layouts).
//!
//! Every read past the end gives zeros, so every byte string is an input.

/// A cursor over the fuzzer's bytes.
pub struct Bytes<'a>(&'a [u8]);

impl<'a> Bytes<'a> {
    /// A cursor at the start of `data`.
    pub fn new(data: &'a [u8]) -> Self {
        Bytes(data)
    }

    /// The next `N` bytes, zeros past the end.
    pub fn array<const N: usize>(&mut self) -> [u8; N] {
        let mut out = [0; N];
        let n = N.min(self.0.len());
        out[..n].copy_from_slice(&self.0[..n]);
        self.0 = &self.0[n..];
        out
    }

    /// The next byte.
    pub fn u8(&mut self) -> u8 {
        self.array::<1>()[0]
    }

    /// The next little-endian `u16`.
    pub fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.array())
    }

    /// The next little-endian `u32`.
    pub fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.array())
    }

    /// The next little-endian `f64`.
    pub fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.array())
    }

    /// Bytes not read yet.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Whether every byte has been read.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The bytes not read yet.
    pub fn rest(self) -> &'a [u8] {
        self.0
    }
}

/// A coordinate in `[-1, 1]` from a `u16` (65,536 levels, so duplicates and
/// exact coplanarity are easy to reach).
pub fn unit(v: u16) -> f32 {
    f32::from(v) / 32767.5 - 1.0
}

use vsaqem::io::{Cloud, Mesh, ReadErrorKind};

/// What a cloud reader promises ([`Cloud`]'s invariant, less non-emptiness,
/// which `read_cloud` checks after the parser): finite positions, one normal
/// and one colour per position when present; an error has a message.
pub fn check_cloud(read: Result<Cloud, ReadErrorKind>) {
    match read {
        Ok(c) => {
            for (i, p) in c.positions.iter().enumerate() {
                assert!(p.iter().all(|v| v.is_finite()), "point {i} is {p:?}");
            }
            if let Some(n) = &c.normals {
                assert_eq!(n.len(), c.positions.len(), "normals");
            }
            if let Some(rgb) = &c.colors {
                assert_eq!(rgb.len(), c.positions.len(), "colours");
            }
        }
        Err(e) => assert!(!e.to_string().is_empty()),
    }
}

/// What a mesh reader promises ([`Mesh`]): finite vertices, every index in
/// range; an error has a message.
pub fn check_mesh(read: Result<Mesh, ReadErrorKind>) {
    match read {
        Ok((vertices, triangles)) => {
            for (i, p) in vertices.iter().enumerate() {
                assert!(p.iter().all(|v| v.is_finite()), "vertex {i} is {p:?}");
            }
            for (i, t) in triangles.iter().enumerate() {
                assert!(
                    t.iter().all(|&v| (v as usize) < vertices.len()),
                    "face {i} is {t:?} with {} vertices",
                    vertices.len()
                );
            }
        }
        Err(e) => assert!(!e.to_string().is_empty()),
    }
}
