"""reconstruct() and cluster(): `vsaqem reconstruct` and `vsaqem cluster` in
process, checked against the CLI itself."""
import os
import pathlib
import subprocess
import warnings

import numpy as np
import pytest

import vsaqem
from test_read_eval import sphere, ticks_during, write_ply

ROOT = pathlib.Path(__file__).resolve().parents[3]
CLI = pathlib.Path(os.environ.get("VSAQEM_BIN", ROOT / "target" / "release" / "vsaqem"))
SHARED = ROOT.parent / "shared" / "data" / "clouds"


def torus(n=4000, R=1.0, r=0.35):
    """n points of a torus (a lattice of angles)."""
    k = int(np.sqrt(n))
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, k, endpoint=False),
                       np.linspace(0, 2 * np.pi, k, endpoint=False))
    u, v = u.ravel(), v.ravel()
    return np.column_stack([(R + r * np.cos(v)) * np.cos(u), (R + r * np.cos(v)) * np.sin(u),
                            r * np.sin(v)])


def read_obj(path):
    """Vertices (float64, every digit) and triangles of an OBJ the CLI wrote."""
    v, f = [], []
    for line in open(path):
        w = line.split()
        if w[:1] == ["v"]:
            v.append([float(x) for x in w[1:4]])
        elif w[:1] == ["f"]:
            f.append([int(x.split("/")[0]) - 1 for x in w[1:4]])
    return np.array(v), np.array(f, np.int32)


def cli_mesh(tmp_path, pts, *args):
    if not CLI.exists():
        pytest.skip(f"needs the CLI at {CLI} (cargo build --release -p vsaqem, or VSAQEM_BIN)")
    write_ply(tmp_path / "in.ply", pts)
    subprocess.run([str(CLI), "reconstruct", "-q", str(tmp_path / "in.ply"), "-o",
                    str(tmp_path / "out.obj"), *args], check=True, capture_output=True)
    return read_obj(tmp_path / "out.obj")


def closed(m):
    """A valid solid: watertight, manifold, oriented, no crossing faces."""
    return m.report["mesh"]["valid_solid"] and m.report["mesh"]["faces"] > 0


@pytest.mark.parametrize("shape, args, kwargs", [
    (sphere(3000), ["--clusters", "150"], {"clusters": 150}),
    (torus(4000), ["--clusters", "300", "--max-error", "0.01", "--knn", "10"],
     {"clusters": 300, "max_error": 0.01, "knn": 10}),
])
def test_the_same_mesh_as_the_cli(tmp_path, shape, args, kwargs):
    # The CLI reads the PLY's float32: give Python the same numbers.
    pts = shape.astype(np.float32)
    v, f = cli_mesh(tmp_path, pts, *args)
    m = vsaqem.reconstruct(pts, **kwargs)
    assert np.array_equal(m.triangles, f)
    assert np.array_equal(m.vertices, v)
    assert closed(m)
    assert m.vertices.dtype == np.float64 and m.triangles.dtype == np.int32


def test_the_bunny_is_the_mesh_the_cli_writes(tmp_path):
    if not (SHARED / "bunny.ply").exists():
        pytest.skip(f"needs {SHARED}/bunny.ply")
    if not CLI.exists():
        pytest.skip(f"needs the CLI at {CLI}")
    subprocess.run([str(CLI), "reconstruct", "-q", str(SHARED / "bunny.ply"), "-o",
                    str(tmp_path / "bunny.obj")], check=True, capture_output=True)
    v, f = read_obj(tmp_path / "bunny.obj")
    m = vsaqem.reconstruct(vsaqem.read(str(SHARED / "bunny.ply")).points)
    assert np.array_equal(m.vertices, v) and np.array_equal(m.triangles, f)
    assert m.report["input"] == {"kind": "array", "points": 34834}


def test_any_memory_order_and_float32_or_64_give_one_mesh():
    pts = sphere(2500)
    a = vsaqem.reconstruct(pts, clusters=120)
    b = vsaqem.reconstruct(np.asfortranarray(pts), clusters=120)
    big = np.zeros((2500, 6))
    big[:, ::2] = pts
    c = vsaqem.reconstruct(big[:, ::2], clusters=120)  # not contiguous
    for m in (b, c):
        assert np.array_equal(m.vertices, a.vertices)
        assert np.array_equal(m.triangles, a.triangles)
    d = vsaqem.reconstruct(pts.astype(np.float32), clusters=120)
    assert closed(d) and len(d.vertices) > 100


def test_deterministic_for_every_thread_count():
    pts = torus(3000)
    runs = [vsaqem.reconstruct(pts, clusters=200, threads=t) for t in (1, 2, 3)]
    for m in runs[1:]:
        assert np.array_equal(m.vertices, runs[0].vertices)
        assert np.array_equal(m.triangles, runs[0].triangles)


@pytest.mark.parametrize("points, match", [
    (np.zeros((100, 2)), r"shape \(N, 3\)"),
    (np.zeros((3,)), r"shape \(N, 3\)"),
    (np.arange(300).reshape(100, 3), "dtype int64 is not float32 or float64"),
    (np.zeros((0, 3)), "no points"),
    (sphere(3), "3 points given; a surface needs at least 4"),
    (np.zeros((100, 3)), "all points coincide"),
    ([[0.0, 0.0, 0.0]] * 10, "numpy array"),
])
def test_bad_points_raise_the_cli_message(points, match):
    with pytest.raises(vsaqem.Error, match=match):
        vsaqem.reconstruct(points)


def test_nan_and_huge_coordinates_are_named():
    pts = sphere(500)
    pts[7, 2] = np.nan
    with pytest.raises(vsaqem.Error, match="points: vertex 7: z is NaN"):
        vsaqem.reconstruct(pts)
    pts[7, 2] = 1e300
    with pytest.raises(vsaqem.Error, match="vertex 7: z is 1e300"):
        vsaqem.reconstruct(pts)


def test_bad_options_raise_the_cli_message():
    pts = sphere(500)
    with pytest.raises(vsaqem.Error, match="invalid value 'many' for 'clusters"):
        vsaqem.reconstruct(pts, clusters="many")
    with pytest.raises(vsaqem.Error, match="cannot enclose a volume"):
        vsaqem.reconstruct(pts, clusters=3)
    with pytest.raises(vsaqem.Error, match="unexpected argument 'colour'"):
        vsaqem.reconstruct(pts, colour=1)
    with pytest.raises(TypeError, match="the mesh is returned"):
        vsaqem.reconstruct(pts, output="m.ply")
    with pytest.raises(vsaqem.Error, match="normals: 2 rows for 500 points"):
        vsaqem.reconstruct(pts, normals=pts[:2])
    with pytest.raises(vsaqem.Error, match="more clusters than points"):
        vsaqem.reconstruct(pts, clusters=600)


def test_normals_and_colours_are_used():
    pts = sphere(3000)
    cols = (np.abs(pts) * 255).astype(np.uint8)
    m = vsaqem.reconstruct(pts, normals=pts, colors=cols, clusters=150)
    assert m.report["normals_given"] is True
    assert m.colors.shape == m.vertices.shape and m.colors.dtype == np.uint8
    assert closed(m)


def test_a_warning_is_a_python_warning():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        vsaqem.reconstruct(sphere(2000), clusters=60, max_error=0.0001)
    assert any("--max-error 0.0001 not met" in str(w.message) for w in caught)


def test_another_thread_runs_while_reconstruct_works():
    pts = torus(20000)
    n, secs = ticks_during(lambda: vsaqem.reconstruct(pts, clusters=500, threads=1))
    assert secs > 0.05, "too quick to tell"
    assert n > 10, f"{n} ticks in the middle of a {secs:.2f} s call"


def test_cluster_labels_every_point():
    pts = sphere(3000)
    k = vsaqem.cluster(pts, clusters=100)
    assert k.points.shape == (3000, 3) and k.labels.shape == (3000,)
    assert k.labels.min() == 0 and k.labels.max() == len(k.generators) - 1
    assert k.report["clusters"] == len(k.generators) >= 100
    # Duplicates are merged first: the same points stored twice cluster alike.
    k2 = vsaqem.cluster(np.vstack([pts, pts]), clusters=100)
    assert np.array_equal(k2.labels, k.labels)
    assert k2.report["duplicates_merged"] == 3000
