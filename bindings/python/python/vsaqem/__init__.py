"""vsaqem: point cloud to compact, feature-preserving, closed triangle mesh
(Variational Shape Reconstruction via Quadric Error Metrics), in process.

    import numpy as np, vsaqem
    mesh = vsaqem.reconstruct(np.asarray(pcd.points), clusters=1000)
    mesh.vertices   # (V, 3) float64, in the points' coordinates
    mesh.triangles  # (F, 3) int32, counter-clockwise seen from outside
    mesh.report     # dict: the CLI's JSON report

Every function raises vsaqem.Error (a ValueError) with the CLI's message on bad
input, and releases the GIL while it works.
"""

from ._vsaqem import Cloud, Clusters, Error, Mesh, cluster, evaluate, read, reconstruct

__all__ = ["Cloud", "Clusters", "Error", "Mesh", "cluster", "evaluate", "read", "reconstruct"]
