"""Reads a GLB written by `vsaqem reconstruct -o MESH.glb` with two independent
glTF readers, pygltflib (the file's structure) and trimesh (the scene, the
node's translation applied), and, given the PLY of the same run, compares the
two meshes' vertices, faces, normals and colours.

    python3 -m venv /tmp/gltf && /tmp/gltf/bin/pip install trimesh pygltflib
    vsaqem reconstruct cloud.ply -o mesh.glb && vsaqem reconstruct cloud.ply -o mesh.ply
    /tmp/gltf/bin/python bench/gltf_check.py mesh.glb mesh.ply

Prints `skipped: ...` and exits 0 when the packages are missing; exits 1 on a
mismatch. The Rust tests (host/tests/output_cli.rs, host/tests/common/glb.rs)
check the same structure without Python; this is a check against other
readers, for benchmarks only.
"""

import sys

try:
    import numpy as np
    import pygltflib
    import trimesh
except ImportError as e:
    print(f"skipped: needs numpy, trimesh and pygltflib ({e})")
    sys.exit(0)

# Without scipy trimesh logs a traceback and falls back to a slower sum.
trimesh.util.log.setLevel("ERROR")


def fail(what):
    print(f"MISMATCH: {what}")
    sys.exit(1)


def main(glb_path, ply_path=None):
    gltf = pygltflib.GLTF2().load_binary(glb_path)
    prim = gltf.meshes[0].primitives[0]
    acc = {name: gltf.accessors[i] for name, i in vars(prim.attributes).items() if i is not None}
    nv = acc["POSITION"].count
    nf = gltf.accessors[prim.indices].count // 3
    blob = gltf.binary_blob()
    if len(blob) != gltf.buffers[0].byteLength:
        fail(f"buffer {gltf.buffers[0].byteLength} bytes, binary chunk {len(blob)}")
    print(f"pygltflib: {nv} vertices, {nf} triangles, attributes {sorted(acc)}, "
          f"translation {gltf.nodes[0].translation}")

    scene = trimesh.load(glb_path, force="scene", process=False)
    mesh = scene.to_geometry() if hasattr(scene, "to_geometry") else scene.dump(concatenate=True)
    print(f"trimesh: {len(mesh.vertices)} vertices, {len(mesh.faces)} faces, "
          f"watertight {mesh.is_watertight}, bounds {mesh.bounds.tolist()}")
    if (len(mesh.vertices), len(mesh.faces)) != (nv, nf):
        fail("trimesh and pygltflib disagree on the counts")
    if ply_path is None:
        return
    ply = trimesh.load(ply_path, process=False)
    if (len(ply.vertices), len(ply.faces)) != (nv, nf):
        fail(f"the PLY has {len(ply.vertices)} vertices and {len(ply.faces)} faces")
    if not np.array_equal(ply.faces, mesh.faces):
        fail("the faces differ")
    far = float(np.abs(np.asarray(ply.vertices) - np.asarray(mesh.vertices)).max())
    print(f"vertices: farthest coordinate apart {far:.3e}")
    if "NORMAL" in acc:
        # The file's normals, read from the buffer, against trimesh's own
        # (angle-weighted, from the faces): the same side, nearly the same way.
        a = acc["NORMAL"]
        view = gltf.bufferViews[a.bufferView]
        start = view.byteOffset + (a.byteOffset or 0)
        n = np.frombuffer(blob, np.float32, 3 * nv, start).reshape(nv, 3)
        length = np.linalg.norm(n, axis=1)
        cos = np.einsum("ij,ij->i", n / length[:, None], np.asarray(mesh.vertex_normals))
        print(f"normals: length {length.min():.6f} .. {length.max():.6f}, "
              f"cosine to trimesh's {cos.min():.4f} .. {cos.max():.4f}")
        if cos.min() <= 0:
            fail("a normal points the other way from trimesh's")
    if "COLOR_0" in acc:
        glb_c = np.asarray(mesh.visual.vertex_colors)[:, :3]
        ply_c = np.asarray(ply.visual.vertex_colors)[:, :3]
        if not np.array_equal(glb_c, ply_c):
            fail("the colours differ")
        print(f"colours: {len(np.unique(glb_c, axis=0))} distinct, equal to the PLY's")
    print("OK")


if __name__ == "__main__":
    if len(sys.argv) not in (2, 3):
        print(__doc__)
        sys.exit(2)
    main(*sys.argv[1:])
