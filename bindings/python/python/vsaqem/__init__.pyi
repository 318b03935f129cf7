"""Type stubs of vsaqem: keyword options are the CLI's (`vsaqem reconstruct
--help`), with `_` for `-`; None (or leaving one out) keeps the CLI's default."""

from os import PathLike
from typing import Any, Literal, Optional, Union

import numpy as np
import numpy.typing as npt

Floats = npt.NDArray[Union[np.float32, np.float64]]

class Error(ValueError):
    """Bad input or parameters, with the message the vsaqem CLI gives."""

class Cloud:
    """A point cloud as the CLI reads it."""
    @property
    def points(self) -> npt.NDArray[np.float64]: ...
    @property
    def normals(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def colors(self) -> Optional[npt.NDArray[np.uint8]]: ...
    @property
    def invalid_skipped(self) -> int: ...

class Mesh:
    """A reconstructed mesh."""
    @property
    def vertices(self) -> npt.NDArray[np.float64]:
        """(V, 3), in the points' coordinates."""
    @property
    def triangles(self) -> npt.NDArray[np.int32]:
        """(F, 3), counter-clockwise seen from outside."""
    @property
    def colors(self) -> Optional[npt.NDArray[np.uint8]]:
        """(V, 3): each vertex its cluster's mean colour, when colours were given."""
    @property
    def report(self) -> dict[str, Any]:
        """The CLI's JSON report (host/report.schema.json, without `file`)."""

class Clusters:
    """Points clustered."""
    @property
    def points(self) -> npt.NDArray[np.float64]:
        """(M, 3): the points clustered, after cleaning and merging exact duplicates."""
    @property
    def labels(self) -> npt.NDArray[np.int32]:
        """(M,): the cluster of each point."""
    @property
    def generators(self) -> npt.NDArray[np.float64]:
        """(C, 3): each cluster's QEM-optimal point."""
    @property
    def report(self) -> dict[str, Any]: ...

def read(path: Union[str, PathLike[str]], *, format: Optional[str] = None) -> Cloud:
    """Read a point cloud with the CLI's readers (PLY, XYZ/TXT/PTS/CSV, PCD,
    LAS/LAZ, E57, OBJ/OFF/STL vertices)."""

def reconstruct(
    points: Floats,
    normals: Optional[Floats] = None,
    colors: Optional[npt.NDArray[np.uint8]] = None,
    *,
    clusters: Optional[int] = 1000,
    max_clusters: Optional[int] = 0,
    max_error: Optional[float] = None,
    iterations: Optional[int] = 5,
    split_iterations: Optional[int] = 2,
    split_rounds: Optional[int] = 5,
    tolerance: Optional[float] = 0.005,
    lambda_: Optional[float] = 0.001,
    knn: Optional[int] = 12,
    seed: Optional[int] = 1,
    partition: Optional[Literal["auto", "grow", "sweep"]] = "auto",
    outliers: Optional[float] = 0.0,
    min_fragment: Optional[int] = 64,
    smooth: Optional[int] = 0,
    epsilon: Optional[float] = 0.01,
    alpha_scale: Optional[float] = 5.0,
    fitting: Optional[float] = 0.4,
    coverage: Optional[float] = 0.3,
    border_penalty: Optional[float] = 2.0,
    max_hole: Optional[int] = 64,
    border_angle: Optional[float] = 150.0,
    node_limit: Optional[int] = 200,
    fit_rounds: Optional[int] = 2,
    densify: Optional[float] = 0.1,
    refine_rounds: Optional[int] = 2,
    refine_beyond: Optional[float] = 0.0075,
    mesh_bytes_per_cluster: Optional[int] = 0,
    allow_empty: bool = False,
    memory: Optional[Union[int, str]] = None,
    threads: Optional[int] = None,
) -> Mesh:
    """Reconstruct a closed mesh from (N, 3) points: `vsaqem reconstruct` in
    process, the same mesh and report. Releases the GIL; raises Error."""

def cluster(
    points: Floats,
    normals: Optional[Floats] = None,
    *,
    clusters: Optional[int] = 1000,
    max_clusters: Optional[int] = 0,
    iterations: Optional[int] = 5,
    split_iterations: Optional[int] = 2,
    split_rounds: Optional[int] = 5,
    tolerance: Optional[float] = 0.005,
    lambda_: Optional[float] = 0.001,
    knn: Optional[int] = 12,
    seed: Optional[int] = 1,
    partition: Optional[Literal["auto", "grow", "sweep"]] = "auto",
    outliers: Optional[float] = 0.0,
    min_fragment: Optional[int] = 64,
    smooth: Optional[int] = 0,
    memory: Optional[Union[int, str]] = None,
    threads: Optional[int] = None,
) -> Clusters:
    """Cluster (N, 3) points: `vsaqem cluster` in process."""

def evaluate(
    points: Floats,
    vertices: Floats,
    triangles: npt.NDArray[Union[np.int32, np.int64, np.uint32]],
    *,
    samples: int = 100000,
    expect_genus: Optional[int] = None,
) -> dict[str, Any]:
    """The `vsaqem eval --json` metrics of a mesh against its points."""
