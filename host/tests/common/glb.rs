//! A structural check of a GLB (glTF 2.0 binary) as vsaqem writes it: the
//! header, the JSON chunk (parsed with serde_json), the binary chunk, and the
//! accessors, views and buffer consistent with each other and with the bytes;
//! every index in range, `min`/`max` equal to the data, normals of unit length.
//! It panics, naming what is wrong, on anything else.

use serde_json::Value;

/// What a GLB holds, read through its accessors.
pub struct Glb {
    /// The JSON chunk.
    pub json: Value,
    /// `POSITION`, as stored (offsets from `translation` when there is one).
    pub positions: Vec<[f32; 3]>,
    /// `NORMAL`, when present.
    pub normals: Option<Vec<[f32; 3]>>,
    /// `COLOR_0`, when present.
    pub colors: Option<Vec<[u8; 3]>>,
    /// The triangle indices.
    pub indices: Vec<u32>,
    /// The node's translation, when present.
    pub translation: Option<[f64; 3]>,
}

impl Glb {
    /// The positions in the scene's coordinates (translation added), `f64`.
    pub fn world(&self) -> Vec<[f64; 3]> {
        let t = self.translation.unwrap_or([0.0; 3]);
        self.positions
            .iter()
            .map(|p| [0, 1, 2].map(|a| t[a] + f64::from(p[a])))
            .collect()
    }
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

fn f32_at(b: &[u8], at: usize) -> f32 {
    f32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

/// Checks `bytes` and reads the mesh (see the module docs).
pub fn check(bytes: &[u8]) -> Glb {
    assert!(bytes.len() >= 20, "{} bytes: no GLB header", bytes.len());
    assert_eq!(&bytes[0..4], b"glTF", "magic");
    assert_eq!(u32_at(bytes, 4), 2, "version");
    assert_eq!(
        u32_at(bytes, 8) as usize,
        bytes.len(),
        "the header's length"
    );
    let json_len = u32_at(bytes, 12) as usize;
    assert_eq!(&bytes[16..20], b"JSON", "the first chunk is JSON");
    assert_eq!(json_len % 4, 0, "the JSON chunk is padded to 4 bytes");
    let json_end = 20 + json_len;
    let json: Value = serde_json::from_slice(&bytes[20..json_end]).expect("the JSON chunk parses");
    assert_eq!(json["asset"]["version"], "2.0");
    let empty = json.get("meshes").is_none();
    if empty {
        assert_eq!(json_end, bytes.len(), "an empty scene has no binary chunk");
        return Glb {
            json,
            positions: Vec::new(),
            normals: None,
            colors: None,
            indices: Vec::new(),
            translation: None,
        };
    }
    let bin_len = u32_at(bytes, json_end) as usize;
    assert_eq!(
        &bytes[json_end + 4..json_end + 8],
        b"BIN\0",
        "the second chunk"
    );
    let bin = &bytes[json_end + 8..];
    assert_eq!(bin.len(), bin_len, "the binary chunk's length");
    assert_eq!(json["buffers"].as_array().unwrap().len(), 1, "one buffer");
    assert_eq!(
        json["buffers"][0]["byteLength"], bin_len,
        "the buffer is the chunk"
    );
    let views = json["bufferViews"].as_array().unwrap();
    for (i, v) in views.iter().enumerate() {
        let (offset, length) = (
            v["byteOffset"].as_u64().unwrap() as usize,
            v["byteLength"].as_u64().unwrap() as usize,
        );
        assert!(offset + length <= bin_len, "view {i} is past the buffer");
        assert_eq!(offset % 4, 0, "view {i} starts on 4 bytes");
    }
    let accessors = json["accessors"].as_array().unwrap();
    // The bytes of accessor `a`, each element's start and the element size.
    let elements = |a: usize, size: usize| -> Vec<usize> {
        let acc = &accessors[a];
        let view = &views[acc["bufferView"].as_u64().unwrap() as usize];
        let count = acc["count"].as_u64().unwrap() as usize;
        assert!(count > 0, "accessor {a} has no elements");
        let stride = view["byteStride"].as_u64().map_or(size, |s| s as usize);
        assert!(
            stride >= size && stride % 4 == 0,
            "accessor {a}: stride {stride}"
        );
        let start = view["byteOffset"].as_u64().unwrap() as usize
            + acc["byteOffset"].as_u64().unwrap_or(0) as usize;
        let length = view["byteLength"].as_u64().unwrap() as usize;
        assert!(
            (count - 1) * stride + size <= length,
            "accessor {a}: {count} elements of {size} bytes do not fit its view of {length}"
        );
        (0..count).map(|i| start + i * stride).collect()
    };
    let vec3_f32 = |a: usize| -> Vec<[f32; 3]> {
        assert_eq!(accessors[a]["componentType"], 5126, "accessor {a}: float");
        assert_eq!(accessors[a]["type"], "VEC3", "accessor {a}");
        elements(a, 12)
            .into_iter()
            .map(|at| [0, 1, 2].map(|k| f32_at(bin, at + 4 * k)))
            .collect()
    };
    let nodes = json["nodes"].as_array().unwrap();
    assert_eq!(nodes.len(), 1);
    let translation = nodes[0]
        .get("translation")
        .map(|t| [0, 1, 2].map(|a| t[a].as_f64().unwrap()));
    let prim = &json["meshes"][0]["primitives"][0];
    assert_eq!(prim["mode"], 4, "triangles");
    let attrs = &prim["attributes"];
    let pos = attrs["POSITION"].as_u64().unwrap() as usize;
    let positions = vec3_f32(pos);
    let nv = positions.len();
    // min and max are those of the data, exactly, read as a viewer reads
    // them: as float32 (serde_json's default parsing of the f64 text may be
    // off by an f64 unit in the last place, far below a float32's).
    for (key, pick) in [("min", f32::min as fn(f32, f32) -> f32), ("max", f32::max)] {
        let bound = &accessors[pos][key];
        for a in 0..3 {
            let want = positions.iter().map(|p| p[a]).reduce(pick).unwrap();
            let got = bound[a].as_f64().unwrap() as f32;
            assert_eq!(got, want, "POSITION {key}[{a}]");
        }
    }
    let normals = attrs.get("NORMAL").map(|n| {
        let n = vec3_f32(n.as_u64().unwrap() as usize);
        assert_eq!(n.len(), nv, "a normal per vertex");
        for v in &n {
            let len = v.iter().map(|c| c * c).sum::<f32>().sqrt();
            assert!(
                (len - 1.0).abs() < 1e-5,
                "normal {v:?} is not of unit length"
            );
        }
        n
    });
    let colors = attrs.get("COLOR_0").map(|c| {
        let a = c.as_u64().unwrap() as usize;
        assert_eq!(
            accessors[a]["componentType"], 5121,
            "COLOR_0: unsigned byte"
        );
        assert_eq!(accessors[a]["normalized"], true, "COLOR_0 is normalised");
        assert_eq!(accessors[a]["type"], "VEC3");
        let c: Vec<[u8; 3]> = elements(a, 3)
            .into_iter()
            .map(|at| [bin[at], bin[at + 1], bin[at + 2]])
            .collect();
        assert_eq!(c.len(), nv, "a colour per vertex");
        c
    });
    let ia = prim["indices"].as_u64().unwrap() as usize;
    assert_eq!(accessors[ia]["componentType"], 5125, "uint32 indices");
    assert_eq!(accessors[ia]["type"], "SCALAR");
    let indices: Vec<u32> = elements(ia, 4)
        .into_iter()
        .map(|at| u32_at(bin, at))
        .collect();
    assert_eq!(indices.len() % 3, 0, "whole triangles");
    assert!(
        indices.iter().all(|&i| (i as usize) < nv),
        "an index is out of range"
    );
    Glb {
        json,
        positions,
        normals,
        colors,
        indices,
        translation,
    }
}
