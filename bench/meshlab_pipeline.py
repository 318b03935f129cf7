#!/usr/bin/env python3
"""MeshLab's point-cloud-to-mesh pipelines (through PyMeshLab), one per process.

    python bench/meshlab_pipeline.py --method poisson|bpa IN.ply OUT.ply N [--depth D]

reads a point cloud without normals, reconstructs a surface with MeshLab's own
filters and decimates it with MeshLab's quadric edge collapse to 2N triangles
(about N vertices on a closed surface), then writes OUT.ply. It is run as its own
process by compare.py, which measures the whole process (wall time, CPU time, peak
RSS), so everything here, the import of PyMeshLab included, counts.

The steps, what a skilled MeshLab user runs, with the parameters compare.py records
next to the results:

  normals   compute_normal_for_point_clouds(k = 15, smoothiter = 2): PCA over the
            15 nearest neighbours, smoothed twice, oriented coherently by MeshLab's
            propagation over the neighbour graph; then flipped as a whole if they
            point inwards on average (sum of (p - centroid) . n < 0), which a user
            would see and fix.
  poisson   generate_surface_reconstruction_screened_poisson(depth = --depth, 8 or
            10; other parameters at MeshLab's defaults), then the vertices whose
            density (MeshLab stores it as the vertex quality) is below the `--trim`
            quantile (0.02: the lowest 2 %) removed, as the Open3D pipeline does.
  bpa       generate_surface_reconstruction_ball_pivoting with radius r, then 2r,
            then 4r (each pass keeps the faces of the previous one), r = the
            average distance from a point to its nearest neighbour; then
            meshing_repair_non_manifold_edges (remove faces),
            meshing_repair_non_manifold_vertices, and meshing_close_holes of up
            to `--max-hole` (100) edges without creating self-intersections.
            (New faces are left unselected: a selection stops the decimation.)
  both      meshing_decimation_quadric_edge_collapse(targetfacenum = 2N,
            qualitythr = 0.3, preservenormal, preservetopology, optimalplacement),
            then unreferenced vertices removed.

Python is used only for benchmarks; this file is not part of vsaqem.
"""

import itertools
import sys

import numpy as np
import pymeshlab

from pipeline_common import Steps, arguments


def average_spacing(v):
    """The mean distance from each point to its nearest other point, exactly. A grid
    of cells h wide finds every neighbour nearer than h (the 27 cells around the
    point's); the few points with none that near are compared with all points."""
    n = len(v)
    lo, ext = v.min(0), np.ptp(v, axis=0)
    area = 2 * (ext[0] * ext[1] + ext[1] * ext[2] + ext[0] * ext[2])
    h = 2 * np.sqrt(area / n) if area > 0 else max(ext.max(), 1e-30) / n
    key = np.floor((v - lo) / h).astype(np.int64) + 1
    dims = key.max(0) + 2
    lin = (key[:, 0] * dims[1] + key[:, 1]) * dims[2] + key[:, 2]
    order = np.argsort(lin, kind="stable")
    sorted_lin = lin[order]
    best = np.full(n, np.inf)
    for dx, dy, dz in itertools.product((-1, 0, 1), repeat=3):
        cell = lin + (dx * dims[1] + dy) * dims[2] + dz
        s = np.searchsorted(sorted_lin, cell, "left")
        cnt = np.searchsorted(sorted_lin, cell, "right") - s
        total = int(cnt.sum())
        if total == 0:
            continue
        p = np.repeat(np.arange(n), cnt)
        q = order[np.repeat(s, cnt) + np.arange(total) - np.repeat(np.cumsum(cnt) - cnt, cnt)]
        d = np.linalg.norm(v[p] - v[q], axis=1)
        d[p == q] = np.inf
        has = np.flatnonzero(cnt)
        np.minimum.at(best, has, np.minimum.reduceat(d, np.cumsum(cnt)[has] - cnt[has]))
    for i in np.flatnonzero(best > h):
        d = np.linalg.norm(v - v[i], axis=1)
        d[i] = np.inf
        best[i] = d.min()
    return float(best.mean())


def main() -> int:
    ap = arguments(__doc__)
    ap.add_argument("--knn", type=int, default=15, help="neighbours for normals (15)")
    ap.add_argument("--smooth", type=int, default=2, help="normal smoothing iterations (2)")
    ap.add_argument("--radii", default="1,2,4",
                    help="BPA: ball radii in multiples of the average spacing (1,2,4)")
    ap.add_argument("--max-hole", type=int, default=100,
                    help="BPA: close holes of up to this many edges (100)")
    a = ap.parse_args()

    steps = Steps(a.method, a.n)
    info, step = steps.info, steps.done

    ms = pymeshlab.MeshSet()
    ms.set_verbosity(False)
    ms.load_new_mesh(a.input)
    if ms.current_mesh().vertex_number() == 0:
        raise SystemExit(f"{a.input}: no points read")
    step("read")
    ms.compute_normal_for_point_clouds(k=a.knn, smoothiter=a.smooth)
    cloud = ms.current_mesh()
    v, nrm = cloud.vertex_matrix(), cloud.vertex_normal_matrix()
    if np.sum((v - v.mean(0)) * nrm) < 0:
        ms.add_mesh(pymeshlab.Mesh(vertex_matrix=v, v_normals_matrix=-nrm), "flipped")
        info["normals_flipped"] = True
    step("normals")

    if a.method == "poisson":
        ms.generate_surface_reconstruction_screened_poisson(depth=a.depth)
        mesh = ms.current_mesh()
        info["poisson_vertices"] = mesh.vertex_number()
        density = mesh.vertex_scalar_array()
        if a.trim > 0 and len(density):
            cut = float(np.quantile(density, a.trim))
            ms.compute_selection_by_condition_per_vertex(condselect=f"(q < {cut!r})")
            ms.meshing_remove_selected_vertices()
        step("poisson")
    else:
        spacing = average_spacing(v)
        radii = [float(x) * spacing for x in a.radii.split(",")]
        info["bpa_radii"] = radii
        step("spacing")
        for r in radii:
            ms.generate_surface_reconstruction_ball_pivoting(
                ballradius=pymeshlab.PureValue(r), deletefaces=False)
        info["bpa_faces"] = ms.current_mesh().face_number()
        step("bpa")
        ms.meshing_repair_non_manifold_edges(method="Remove Faces")
        ms.meshing_repair_non_manifold_vertices()
        ms.meshing_close_holes(maxholesize=a.max_hole, selfintersection=True,
                              newfaceselected=False)
        step("repair")
    info["surface_faces"] = ms.current_mesh().face_number()
    if info["surface_faces"] == 0:
        raise SystemExit(f"{a.method}: the reconstruction has no faces")

    # A face selection left by an earlier filter would stop the decimation early.
    ms.set_selection_none()
    ms.meshing_decimation_quadric_edge_collapse(
        targetfacenum=2 * a.n, qualitythr=0.3, preservenormal=True, preservetopology=True,
        optimalplacement=True)
    ms.meshing_remove_unreferenced_vertices()
    step("decimate")
    mesh = ms.current_mesh()
    info["vertices"] = mesh.vertex_number()
    info["faces"] = mesh.face_number()
    if info["faces"] == 0:
        raise SystemExit(f"{a.method}: decimation left no faces")
    # No normals, colours or quality: the file holds what is measured, as vsaqem's does.
    ms.save_current_mesh(a.output, binary=True, save_vertex_normal=False,
                         save_vertex_color=False, save_vertex_quality=False,
                         save_face_color=False, save_face_quality=False)
    step("write")
    steps.write(a.info)
    return 0


if __name__ == "__main__":
    sys.exit(main())
