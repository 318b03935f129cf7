"""read() and evaluate(): the CLI's readers and `vsaqem eval`, from numpy."""
import struct
import threading

import numpy as np
import pytest

import vsaqem


def sphere(n=2000, r=1.0):
    """n points of a Fibonacci sphere of radius r."""
    i = np.arange(n) + 0.5
    y = 1 - 2 * i / n
    s = np.sqrt(1 - y * y)
    t = np.pi * (3 - np.sqrt(5)) * i
    return r * np.column_stack([s * np.cos(t), y, s * np.sin(t)])


def octahedron(r=1.0):
    v = r * np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
    f = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4],
                  [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]], np.int32)
    return v, f


def write_ply(path, pts):
    with open(path, "wb") as f:
        f.write(b"ply\nformat binary_little_endian 1.0\n")
        f.write(f"element vertex {len(pts)}\n".encode())
        f.write(b"property float x\nproperty float y\nproperty float z\nend_header\n")
        f.write(np.asarray(pts, "<f4").tobytes())


def test_read_gives_the_points_as_float64(tmp_path):
    pts = sphere(500)
    write_ply(tmp_path / "s.ply", pts)
    cloud = vsaqem.read(str(tmp_path / "s.ply"))
    assert cloud.points.shape == (500, 3) and cloud.points.dtype == np.float64
    assert np.array_equal(cloud.points, pts.astype(np.float32).astype(np.float64))
    assert cloud.normals is None and cloud.colors is None and cloud.invalid_skipped == 0
    assert repr(cloud) == "Cloud(500 points)"


def test_read_errors_name_the_file_and_the_place(tmp_path):
    with pytest.raises(vsaqem.Error, match="missing.ply"):
        vsaqem.read(str(tmp_path / "missing.ply"))
    bad = tmp_path / "bad.xyz"
    bad.write_text("0 0 0\n1 1 1\n1 two 3\n")
    with pytest.raises(ValueError, match="line 3"):
        vsaqem.read(str(bad))


def test_evaluate_measures_an_octahedron_against_its_vertices():
    v, f = octahedron()
    e = vsaqem.evaluate(v, v, f, samples=1000)
    assert e["topology"]["closed_manifold"] is True
    assert e["validity"]["valid_solid"] is True
    assert e["point_to_mesh"]["distance"]["max"] == pytest.approx(0.0, abs=1e-12)
    # Any memory order and float32 give the same figures.
    e2 = vsaqem.evaluate(np.asfortranarray(v).astype(np.float32), v[::1], f.astype(np.int64),
                         samples=1000)
    assert e2["hausdorff"] == pytest.approx(e["hausdorff"])


@pytest.mark.parametrize("bad, match", [
    (np.zeros((4, 2)), r"shape \(N, 3\)"),
    (np.zeros((4, 3), np.int64), "dtype int64"),
    ([[0.0, 0.0, 0.0]], "numpy array"),
    (np.array([[0.0, 0.0, np.nan]] * 4), "row 0: coordinate z is NaN"),
])
def test_evaluate_rejects_bad_points(bad, match):
    v, f = octahedron()
    with pytest.raises(vsaqem.Error, match=match):
        vsaqem.evaluate(bad, v, f)


def test_evaluate_rejects_bad_triangles():
    v, f = octahedron()
    with pytest.raises(vsaqem.Error, match="triangle 1 is"):
        vsaqem.evaluate(v, v, np.array([[0, 1, 2], [0, 1, 6]]))
    with pytest.raises(vsaqem.Error, match="vertex index -1"):
        vsaqem.evaluate(v, v, np.array([[0, 1, -1]]))
    with pytest.raises(vsaqem.Error, match="no faces"):
        vsaqem.evaluate(v, v, np.zeros((0, 3), np.int32))
    with pytest.raises(vsaqem.Error, match="not an integer type"):
        vsaqem.evaluate(v, v, f.astype(float))


def ticks_during(work):
    """Timestamps another Python thread records while `work()` runs, from the
    middle half of the call: with the GIL held throughout, there are none."""
    import time

    ticks = []
    done = threading.Event()

    def count():
        while not done.is_set():
            ticks.append(time.perf_counter())

    t = threading.Thread(target=count)
    t.start()
    t0 = time.perf_counter()
    work()
    t1 = time.perf_counter()
    done.set()
    t.join()
    lo, hi = t0 + 0.25 * (t1 - t0), t0 + 0.75 * (t1 - t0)
    return sum(lo <= x <= hi for x in ticks), t1 - t0


def test_evaluate_releases_the_gil():
    pts = sphere(20000)
    v, f = octahedron()
    n, secs = ticks_during(lambda: vsaqem.evaluate(pts, v, f, samples=50000))
    assert secs > 0.05, "too quick to tell"
    assert n > 10, f"{n} ticks in the middle of a {secs:.2f} s call"
