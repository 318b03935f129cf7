#!/usr/bin/env python3
"""Open3D 0.20's native point-cloud-to-mesh pipelines, one per process.

    python bench/o3d_pipeline.py --method poisson|bpa IN.ply OUT.ply N

reads a point cloud without normals, reconstructs a surface with Open3D's own
tools and decimates it with Open3D's quadric decimation to 2N triangles (about N
vertices on a closed surface), then writes OUT.ply. It is run as its own process by
compare.py, which measures the whole process (wall time, CPU time, peak RSS), so
everything here, the import of Open3D included, counts.

The steps, with the parameters compare.py records next to the results:

  normals   estimate_normals over the K nearest neighbours (K = 20, as the paper's
            KNN), then orient_normals_consistent_tangent_plane(K).
  poisson   create_from_point_cloud_poisson(depth = 8, Open3D's default), then the
            vertices whose density is below the `--trim` quantile (0.02: the lowest
            2 %) are removed, as Open3D's tutorial does.
  bpa       create_from_point_cloud_ball_pivoting with radii (r, 2r),
            r = 3 x the average nearest-neighbour distance.
  both      simplify_quadric_decimation(target_number_of_triangles = 2N), then
            unreferenced vertices removed.

Python is used only for benchmarks; this file is not part of vsaqem.
"""

import sys

import numpy as np
import open3d as o3d

from pipeline_common import Steps, arguments


def main() -> int:
    ap = arguments(__doc__)
    ap.add_argument("--knn", type=int, default=20, help="neighbours for normals (20)")
    ap.add_argument("--bpa-scale", type=float, default=3.0,
                    help="BPA: r = scale x mean nearest-neighbour distance (3)")
    a = ap.parse_args()

    o3d.utility.random.seed(1)
    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    steps = Steps(a.method, a.n)
    info, step = steps.info, steps.done

    pcd = o3d.io.read_point_cloud(a.input)
    if len(pcd.points) == 0:
        raise SystemExit(f"{a.input}: no points read")
    step("read")
    pcd.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(knn=a.knn))
    pcd.orient_normals_consistent_tangent_plane(a.knn)
    step("normals")

    if a.method == "poisson":
        mesh, density = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(
            pcd, depth=a.depth)
        density = np.asarray(density)
        info["poisson_vertices"] = len(mesh.vertices)
        if a.trim > 0 and len(density):
            mesh.remove_vertices_by_mask(density < np.quantile(density, a.trim))
        step("poisson")
    else:
        spacing = float(np.mean(pcd.compute_nearest_neighbor_distance()))
        r = a.bpa_scale * spacing
        info["bpa_radii"] = [r, 2 * r]
        mesh = o3d.geometry.TriangleMesh.create_from_point_cloud_ball_pivoting(
            pcd, o3d.utility.DoubleVector([r, 2 * r]))
        step("bpa")
    info["surface_faces"] = len(mesh.triangles)
    if len(mesh.triangles) == 0:
        raise SystemExit(f"{a.method}: the reconstruction has no faces")

    mesh = mesh.simplify_quadric_decimation(target_number_of_triangles=2 * a.n)
    mesh.remove_unreferenced_vertices()
    step("decimate")
    info["vertices"] = len(mesh.vertices)
    info["faces"] = len(mesh.triangles)
    if len(mesh.triangles) == 0:
        raise SystemExit(f"{a.method}: decimation left no faces")
    # No normals or colours: the file holds what is measured, as vsaqem's does.
    mesh.vertex_normals = o3d.utility.Vector3dVector()
    mesh.vertex_colors = o3d.utility.Vector3dVector()
    if not o3d.io.write_triangle_mesh(a.output, mesh, write_ascii=False):
        raise SystemExit(f"{a.output}: Open3D could not write the mesh")
    step("write")
    steps.write(a.info)
    return 0


if __name__ == "__main__":
    sys.exit(main())
