"""same_mesh.py A.ply B.ply: exit 0 when two binary little-endian PLY meshes
have the same vertex positions (float x y z, bit for bit; other vertex
properties ignored) and the same triangles, else say where they differ."""
import struct
import sys


def read(path):
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    nv = nf = 0
    props = []
    element = None
    for line in header:
        w = line.split()
        if w[:1] == ["element"]:
            element = w[1]
            if element == "vertex":
                nv = int(w[2])
            elif element == "face":
                nf = int(w[2])
        elif w[:1] == ["property"] and element == "vertex":
            if w[1] != "float":
                sys.exit(f"{path}: vertex property {w[-1]} is {w[1]}, only float is read")
            props.append(w[-1])
    stride = 4 * len(props)
    xyz = [props.index(a) for a in "xyz"]
    vertices = []
    at = end
    for _ in range(nv):
        row = struct.unpack_from(f"<{len(props)}f", data, at)
        vertices.append(tuple(row[i] for i in xyz))
        at += stride
    faces = []
    for _ in range(nf):
        (count,) = struct.unpack_from("<B", data, at)
        faces.append(struct.unpack_from(f"<{count}i", data, at + 1))
        at += 1 + 4 * count
    return vertices, faces


a, b = read(sys.argv[1]), read(sys.argv[2])
if len(a[0]) != len(b[0]) or len(a[1]) != len(b[1]):
    sys.exit(f"different sizes: {len(a[0])} vertices, {len(a[1])} faces against "
             f"{len(b[0])}, {len(b[1])}")
for i, (p, q) in enumerate(zip(a[0], b[0])):
    if struct.pack("<3f", *p) != struct.pack("<3f", *q):
        sys.exit(f"vertex {i}: {p} against {q}")
for i, (p, q) in enumerate(zip(a[1], b[1])):
    if p != q:
        sys.exit(f"face {i}: {p} against {q}")
print(f"same mesh: {len(a[0])} vertices, {len(a[1])} faces")
