/* vsaqem: point cloud to closed triangle mesh (VSA-QEM) in a caller-supplied
 * buffer. No allocation, no unwinding. Generated from bindings/c/src/lib.rs by
 * cbindgen: do not edit; run bindings/c/build.sh. */

#ifndef VSAQEM_H
#define VSAQEM_H

#include <stddef.h>
#include <stdint.h>

// Success.
#define VSAQEM_OK 0

// A pointer that must not be null is null (`buffer`, `points`, `params`).
#define VSAQEM_NULL_POINTER 1

// `buffer_len` cannot even hold the arrays of these points (checked before any
// work; [`vsaqem_arena_bytes`] is always enough).
#define VSAQEM_BUFFER_TOO_SMALL 2

// The arena inside the buffer ran out (does not happen in a buffer of
// [`vsaqem_arena_bytes`] bytes).
#define VSAQEM_EXHAUSTED 3

// Fewer points than a surface needs.
#define VSAQEM_TOO_FEW_POINTS 4

// A coordinate is NaN or infinite (the message names the point and axis).
#define VSAQEM_NON_FINITE 5

// The points coincide, or lie on one line or one plane.
#define VSAQEM_DEGENERATE 6

// `k` is outside `1..=32` or not below the number of points.
#define VSAQEM_BAD_NEIGHBOURS 7

// A parameter is outside its documented range (the message names it).
#define VSAQEM_BAD_PARAMETER 8

// More points than core supports.
#define VSAQEM_TOO_MANY_POINTS 9

// The candidate graph is denser than the meshing capacity
// (`mesh_bytes_per_cluster`): use fewer clusters or raise it.
#define VSAQEM_MESH_CAPACITY 10

// The buffer is smaller than [`vsaqem_arena_bytes`] and this cloud needs more
// (the message says how much).
#define VSAQEM_ARENA_TOO_SMALL 11

// Cleaning would leave too few points (lower `outlier_sigma` or `min_fragment`).
#define VSAQEM_TOO_FEW_KEPT 12

// The mesh has no faces (e.g. fewer than 4 clusters cannot enclose a volume).
#define VSAQEM_EMPTY_MESH 13

// An error this interface cannot cause (a bug: please report it).
#define VSAQEM_INTERNAL 14

// [`vsaqem_params::partition`]: sweeps from 131,072 points, region growing below.
#define VSAQEM_PARTITION_AUTO 0

// [`vsaqem_params::partition`]: region growing from the seeds.
#define VSAQEM_PARTITION_GROW 1

// [`vsaqem_params::partition`]: synchronous sweeps.
#define VSAQEM_PARTITION_SWEEP 2

// Bytes of [`vsaqem_mesh::message`], its terminating NUL included.
#define VSAQEM_MESSAGE_BYTES 256

// Every parameter of a run, as `vsaqem reconstruct` has them (its option of
// the same name, with `-` for `_`). Start from [`vsaqem_params_default`] and
// change what you need: distances are fractions of the bounding-box diagonal.
typedef struct vsaqem_params {
  // Neighbours per point, `1..=32`. Default 12.
  uint32_t k;
  // Initial clusters (about the mesh's vertices). Default 1000.
  uint32_t clusters;
  // Cap splitting and refinement may reach; 0: twice `clusters`. Default 0.
  uint32_t max_clusters;
  // Partition and update passes before splitting. Default 5.
  uint32_t iterations;
  // Passes after each splitting batch. Default 2.
  uint32_t split_iterations;
  // Splitting batches at most. Default 5.
  uint32_t split_rounds;
  // Largest QEM error of a cluster, a fraction of the diagonal; 0: no
  // splitting. Default 0.005.
  float tolerance;
  // Weight of the Euclidean term in the partition cost. Default 0.001.
  float lambda;
  // Seed of the generator initialisation. Default 1.
  uint64_t seed;
  // Support distance of the facet scores. Default 0.01.
  float epsilon;
  // Coverage radius in average spacings. Default 5.
  float alpha_scale;
  // Weight of the fitting term of a facet's score. Default 0.4.
  float fitting_weight;
  // Weight of the coverage term of a facet's score. Default 0.3.
  float coverage_weight;
  // Cost of a selected edge left without a partner. Default 2.
  float border_penalty;
  // Longest hole (in edges) filled; 0: none. Default 64.
  uint32_t max_hole;
  // Angle in degrees beyond which a cluster lies on the border of the data;
  // 360: no border. Default 150.
  float border_angle;
  // `VSAQEM_PARTITION_AUTO`, `_GROW` or `_SWEEP`. Default auto.
  uint32_t partition;
  // Branch-and-bound nodes of the facet selection. Default 200.
  uint64_t node_limit;
  // Rounds of fitting the vertices to the data. Default 2.
  uint32_t fit_rounds;
  // Fraction of vertices added where the mesh is farthest from the data,
  // `0..=1`. Default 0.1.
  float densify;
  // Refinement rounds for clusters left out, then one more where some still
  // are, kept only if it leaves out no more points (0: none). Default 2.
  uint32_t refine_rounds;
  // Error bound (0: none). Default 0.
  float max_error;
  // Distance beyond which refinement rounds run without a bound. Default 0.0075.
  float refine_beyond;
  // Meshing memory per cluster of the cap in bytes; 0: `400 sqrt(k)`. Default 0.
  uint32_t mesh_bytes_per_cluster;
  // Statistical outlier filter in standard deviations; 0: off. Default 0.
  float outlier_sigma;
  // Pieces of fewer points are dropped; 0: off. Default 64.
  uint32_t min_fragment;
  // Smoothing rounds before reconstruction. Default 0.
  uint32_t smooth_rounds;
} vsaqem_params;

// A reconstructed mesh, or why there is none.
//
// `vertices` and `triangles` point into the caller's buffer: they are valid
// until the buffer is freed or used for another run.
typedef struct vsaqem_mesh {
  // `3 * vertex_count` floats: x, y, z of each vertex, in the coordinates
  // of the points given (null on error).
  const float *vertices;
  // Vertices of the mesh.
  size_t vertex_count;
  // `3 * triangle_count` vertex indices, counter-clockwise seen from
  // outside (null on error).
  const uint32_t *triangles;
  // Triangles of the mesh.
  size_t triangle_count;
  // Edges with one face (0: closed).
  uint32_t boundary_edges;
  // Edge-connected pieces of the mesh.
  uint32_t components;
  // Clusters the mesh was made from.
  uint32_t clusters;
  // Points reconstructed (after merging duplicates and cleaning).
  size_t points_used;
  // Exact duplicates merged into the first point at their position (its
  // normal kept).
  size_t duplicates_merged;
  // Points cleaning removed (outliers and small fragments).
  size_t points_removed;
  // Distance from the farthest point used to the mesh, in the points' units.
  double max_distance;
  // Diagonal of the bounding box of the points used, in their units.
  double diagonal;
  // Bytes of the buffer the run used at most.
  size_t buffer_peak;
  // What [`vsaqem_arena_bytes`] gives for this run (a buffer this large
  // never runs out).
  size_t buffer_needed;
  // On error, what went wrong, as the CLI says it; empty on success.
  // NUL-terminated.
  char message[VSAQEM_MESSAGE_BYTES];
} vsaqem_mesh;

#ifdef __cplusplus
extern "C" {
#endif // __cplusplus

// The default parameters (those of `vsaqem reconstruct`).
struct vsaqem_params vsaqem_params_default(void);

// Bytes of buffer that are always enough for [`vsaqem_reconstruct`] on `n`
// points with `params` (with or without normals). `SIZE_MAX` when `params` is
// null or invalid, or the size does not fit in a `size_t`.
//
// # Safety
// `params` is null or points to a `vsaqem_params`.
size_t vsaqem_arena_bytes(size_t n, const struct vsaqem_params *params);

// A short description of a status code, NUL-terminated, static.
const char *vsaqem_error_message(int32_t status);

// Reconstruct a mesh from `n` points (`points`: `3 n` floats, x y z of each)
// and, when `normals` is not null, their normals (`3 n` floats; a zero or
// non-finite normal is estimated instead), in `buffer` (`buffer_len` bytes,
// any alignment; [`vsaqem_arena_bytes`] are always enough; fewer may do, down
// to what this cloud needs: `VSAQEM_ARENA_TOO_SMALL` says when they do not, and
// a run that succeeds in fewer gives the same mesh). Writes the
// result, or the reason there is none, to `*out` and returns a `VSAQEM_*`
// status. Never allocates, never reads or writes outside the given arrays, and
// gives the same mesh for the same input every time, on every target.
//
// # Safety
// `out` points to a writable `vsaqem_mesh`; `buffer` to `buffer_len` writable
// bytes that nothing else uses during the call; `points` (and `normals`, when
// not null) to `3 n` readable floats; `params` to a `vsaqem_params`.
int32_t vsaqem_reconstruct(void *buffer,
                           size_t buffer_len,
                           const float *points,
                           size_t n,
                           const float *normals,
                           const struct vsaqem_params *params,
                           struct vsaqem_mesh *out);

#ifdef __cplusplus
}  // extern "C"
#endif  // __cplusplus

#endif  /* VSAQEM_H */
