//! glTF 2.0 binary (GLB, Khronos glTF 2.0 specification, section 4.4): one
//! file of a 12-byte header, a JSON chunk that describes the scene and a
//! binary chunk that holds the arrays.
//!
//! What is written: one scene of one node holding one mesh of one triangle
//! primitive; one buffer (the binary chunk), cut into tightly packed views in
//! this order: positions (`float32` `VEC3`, with the `min` and `max` the
//! format requires), normals (`float32` `VEC3`) and colours (`uint8` `VEC3`,
//! normalised, a stride of 4 bytes because each vertex attribute must start on
//! 4 bytes) when given, then the indices (`uint32`). Every view's length is a
//! multiple of 4, so no padding lies between them. In [`Coords::F32Offset`]
//! the positions are offsets from the layout's origin and the node's
//! `translation` is that origin, in `float64` (JSON numbers). A mesh without
//! triangles is a scene without nodes and no buffer.
//!
//! Cost: one pass over the vertices for `min`/`max`, then the arrays streamed
//! in 64 KiB writes; the JSON is a few hundred bytes.

use super::invalid;
use super::mesh::{Coords, MeshLayout, MeshOut};
use serde_json::{json, Value};
use std::io::{self, Write};

/// `glTF`, the file's magic number.
pub const MAGIC: u32 = 0x4654_6C67;
/// The chunk type of the JSON chunk (`JSON`).
pub const JSON_CHUNK: u32 = 0x4E4F_534A;
/// The chunk type of the binary chunk (`BIN\0`).
pub const BIN_CHUNK: u32 = 0x004E_4942;

/// Accessor component types and buffer view targets (the OpenGL enums).
const FLOAT: u32 = 5126;
const UNSIGNED_BYTE: u32 = 5121;
const UNSIGNED_INT: u32 = 5125;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
/// Primitive mode: triangles.
const TRIANGLES: u32 = 4;

/// Writes `mesh` as GLB (see the module docs). A file of 4 GiB or more (the
/// format's 32-bit length) is an `InvalidInput` error, found before a byte is
/// written.
pub(super) fn write_glb(w: &mut dyn Write, layout: &MeshLayout, mesh: &MeshOut) -> io::Result<()> {
    let nv = mesh.vertices.len();
    let json = if mesh.triangles.is_empty() {
        empty_scene()
    } else {
        scene(layout, mesh)
    };
    let mut json = serde_json::to_vec(&json).map_err(io::Error::other)?;
    // The JSON chunk is padded with spaces to 4 bytes.
    json.resize(json.len().next_multiple_of(4), b' ');
    let bin = if mesh.triangles.is_empty() {
        0
    } else {
        let per_vertex = 12
            + if mesh.normals.is_some() { 12 } else { 0 }
            + if mesh.colors.is_some() { 4 } else { 0 };
        (nv as u64) * per_vertex + 12 * mesh.triangles.len() as u64
    };
    let total = 12 + 8 + json.len() as u64 + if bin > 0 { 8 + bin } else { 0 };
    let too_large = || {
        invalid(format!(
            "a GLB of {total} bytes is past the format's limit of 4 GiB; write .ply"
        ))
    };
    let total = u32::try_from(total).map_err(|_| too_large())?;
    let bin = u32::try_from(bin).map_err(|_| too_large())?;
    let json_len = u32::try_from(json.len()).map_err(|_| too_large())?;
    let mut head = Vec::with_capacity(20);
    for word in [MAGIC, 2, total, json_len, JSON_CHUNK] {
        head.extend_from_slice(&word.to_le_bytes());
    }
    w.write_all(&head)?;
    w.write_all(&json)?;
    if bin == 0 {
        return Ok(());
    }
    w.write_all(&bin.to_le_bytes())?;
    w.write_all(&BIN_CHUNK.to_le_bytes())?;
    let mut buf = Vec::with_capacity(1 << 16);
    let mut put = |w: &mut dyn Write, bytes: &[u8]| -> io::Result<()> {
        if buf.len() + bytes.len() > 1 << 16 {
            w.write_all(&buf)?;
            buf.clear();
        }
        buf.extend_from_slice(bytes);
        Ok(())
    };
    for &p in mesh.vertices {
        put(w, &le_f32(layout.local(p)))?;
    }
    for &n in mesh.normals.unwrap_or_default() {
        put(w, &le_f32(n))?;
    }
    for &[r, g, b] in mesh.colors.unwrap_or_default() {
        put(w, &[r, g, b, 0])?;
    }
    for t in mesh.triangles {
        let mut bytes = [0u8; 12];
        for (k, i) in t.iter().enumerate() {
            bytes[4 * k..4 * k + 4].copy_from_slice(&i.to_le_bytes());
        }
        put(w, &bytes)?;
    }
    w.write_all(&buf)
}

/// Three `f32` as 12 little-endian bytes.
fn le_f32(v: [f32; 3]) -> [u8; 12] {
    let mut b = [0u8; 12];
    for (k, c) in v.iter().enumerate() {
        b[4 * k..4 * k + 4].copy_from_slice(&c.to_le_bytes());
    }
    b
}

/// The `asset` object.
fn asset() -> Value {
    json!({
        "version": "2.0",
        "generator": concat!("vsaqem ", env!("CARGO_PKG_VERSION")),
    })
}

/// A glTF with one empty scene.
fn empty_scene() -> Value {
    json!({ "asset": asset(), "scene": 0, "scenes": [{ "nodes": [] }] })
}

/// The JSON of a mesh with triangles (see the module docs).
fn scene(layout: &MeshLayout, mesh: &MeshOut) -> Value {
    let nv = mesh.vertices.len();
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for &p in mesh.vertices {
        let q = layout.local(p);
        for a in 0..3 {
            lo[a] = lo[a].min(q[a]);
            hi[a] = hi[a].max(q[a]);
        }
    }
    // JSON numbers are f64: each bound as the f64 equal to the f32 (so a
    // reader that compares them with the data finds them exact).
    let bound = |v: [f32; 3]| v.map(f64::from).to_vec();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut offset = 0u64;
    let mut view = |length: u64, stride: Option<u32>, target: u32| {
        let mut v = json!({
            "buffer": 0,
            "byteOffset": offset,
            "byteLength": length,
            "target": target,
        });
        if let Some(s) = stride {
            v["byteStride"] = s.into();
        }
        offset += length;
        views.push(v);
        views.len() - 1
    };
    let mut attributes = serde_json::Map::new();
    let positions = view(12 * nv as u64, None, ARRAY_BUFFER);
    accessors.push(json!({
        "bufferView": positions,
        "componentType": FLOAT,
        "count": nv,
        "type": "VEC3",
        "min": bound(lo),
        "max": bound(hi),
    }));
    attributes.insert("POSITION".into(), (accessors.len() - 1).into());
    if mesh.normals.is_some() {
        let normals = view(12 * nv as u64, None, ARRAY_BUFFER);
        accessors.push(json!({
            "bufferView": normals,
            "componentType": FLOAT,
            "count": nv,
            "type": "VEC3",
        }));
        attributes.insert("NORMAL".into(), (accessors.len() - 1).into());
    }
    if mesh.colors.is_some() {
        let colors = view(4 * nv as u64, Some(4), ARRAY_BUFFER);
        accessors.push(json!({
            "bufferView": colors,
            "componentType": UNSIGNED_BYTE,
            "normalized": true,
            "count": nv,
            "type": "VEC3",
        }));
        attributes.insert("COLOR_0".into(), (accessors.len() - 1).into());
    }
    let indices = view(12 * mesh.triangles.len() as u64, None, ELEMENT_ARRAY_BUFFER);
    accessors.push(json!({
        "bufferView": indices,
        "componentType": UNSIGNED_INT,
        "count": 3 * mesh.triangles.len(),
        "type": "SCALAR",
    }));
    let mut node = json!({ "mesh": 0 });
    if let (Coords::F32Offset, Some(origin)) = (layout.coords(), layout.origin()) {
        node["translation"] = origin.to_vec().into();
    }
    json!({
        "asset": asset(),
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [node],
        "meshes": [{
            "primitives": [{
                "attributes": attributes,
                "indices": accessors.len() - 1,
                "mode": TRIANGLES,
            }],
        }],
        "buffers": [{ "byteLength": offset }],
        "bufferViews": views,
        "accessors": accessors,
    })
}
