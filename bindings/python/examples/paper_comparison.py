#!/usr/bin/env python3
"""The paper's comparison, from Python: VSA-QEM against Open3D's point-cloud
pipeline (normals, orientation, screened Poisson, density trim, quadric
decimation to the same size), both measured by vsaqem.evaluate.

    python paper_comparison.py [CLOUD.ply] [--clusters N]

Needs `pip install ./bindings/python open3d` (Open3D 0.20 also needs the system
library libusb-1.0). Without CLOUD, the bunny of ../shared/data/clouds.
"""

import argparse
import pathlib
import time

import numpy as np
import open3d as o3d

import vsaqem

HERE = pathlib.Path(__file__).resolve()
BUNNY = HERE.parents[4] / "shared" / "data" / "clouds" / "bunny.ply"


def open3d_poisson(points, n):
    """Open3D's pipeline (as in its tutorial and the paper's baseline), to
    about n vertices: 2n triangles."""
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    pcd.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(20))
    pcd.orient_normals_consistent_tangent_plane(20)
    mesh, density = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(pcd, depth=8)
    density = np.asarray(density)
    mesh.remove_vertices_by_mask(density < np.quantile(density, 0.02))
    mesh = mesh.simplify_quadric_decimation(target_number_of_triangles=2 * n)
    mesh.remove_unreferenced_vertices()
    return np.asarray(mesh.vertices), np.asarray(mesh.triangles)


def row(name, points, vertices, triangles, seconds):
    e = vsaqem.evaluate(points, vertices, triangles, samples=100000)
    m = e["topology"]
    print(f"{name:<10} {len(vertices):>8} {len(triangles):>9} {m['boundary_edges']:>9} "
          f"{str(e['validity']['valid_solid']):>6} {100 * e['point_to_mesh']['distance']['max_relative']:>8.3f} "
          f"{100 * e['chamfer_relative']:>9.4f} {seconds:>7.2f}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("cloud", nargs="?", default=str(BUNNY))
    ap.add_argument("--clusters", type=int, default=1000)
    a = ap.parse_args()
    points = vsaqem.read(a.cloud).points
    print(f"{a.cloud}: {len(points)} points")
    print(f"{'':<10} {'vertices':>8} {'triangles':>9} {'boundary':>9} {'solid':>6} "
          f"{'max %':>8} {'chamfer %':>9} {'seconds':>7}")
    t = time.perf_counter()
    mesh = vsaqem.reconstruct(points, clusters=a.clusters)
    row("vsaqem", points, mesh.vertices, mesh.triangles, time.perf_counter() - t)
    t = time.perf_counter()
    v, f = open3d_poisson(points, len(mesh.vertices))
    row("open3d", points, v, f, time.perf_counter() - t)


if __name__ == "__main__":
    main()
