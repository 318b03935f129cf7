/* vsaqem from C: reconstruct a point cloud into a closed mesh.
 *
 *   reconstruct                      checks on generated spheres (the test)
 *   reconstruct IN.ply [OUT.ply] [CLUSTERS]
 *                                    reconstructs a binary little-endian PLY
 *                                    cloud (float x y z first), checks the mesh
 *                                    is closed and writes it as PLY
 *
 * Exits 0 when every check holds, 1 otherwise (saying which failed). */
#include "vsaqem.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static int failures = 0;

#define CHECK(cond, ...)                                                   \
    do {                                                                   \
        if (!(cond)) {                                                     \
            fprintf(stderr, "FAIL %s:%d: %s: ", __FILE__, __LINE__, #cond); \
            fprintf(stderr, __VA_ARGS__);                                  \
            fprintf(stderr, "\n");                                         \
            failures++;                                                    \
        }                                                                  \
    } while (0)

/* n points on a sphere of radius r about c (a Fibonacci lattice). */
static float *sphere(size_t n, float r, const float c[3]) {
    float *p = malloc(3 * n * sizeof *p);
    if (!p) return NULL;
    const double golden = 3.14159265358979323846 * (3.0 - sqrt(5.0));
    for (size_t i = 0; i < n; i++) {
        double y = 1.0 - 2.0 * (i + 0.5) / n, s = sqrt(1.0 - y * y), t = golden * i;
        p[3 * i] = c[0] + r * (float)(s * cos(t));
        p[3 * i + 1] = c[1] + r * (float)y;
        p[3 * i + 2] = c[2] + r * (float)(s * sin(t));
    }
    return p;
}

/* The mesh is a closed 2-manifold of one piece and genus g: every index in
 * range, no border, V - E + F = 2 - 2g with E = 3F/2. */
static int closed_with_genus(const vsaqem_mesh *m, int genus) {
    for (size_t i = 0; i < 3 * m->triangle_count; i++)
        if (m->triangles[i] >= m->vertex_count) return 0;
    for (size_t i = 0; i < 3 * m->vertex_count; i++)
        if (!isfinite(m->vertices[i])) return 0;
    long v = (long)m->vertex_count, f = (long)m->triangle_count;
    return m->boundary_edges == 0 && m->components == 1 && f % 2 == 0 &&
           2 * v - f == 4 - 4 * genus;
}

static void sphere_checks(void) {
    const size_t n = 3000;
    const float centre[3] = {1000.0f, -20.0f, 5.0f};
    float *pts = sphere(n, 2.5f, centre);
    vsaqem_params p = vsaqem_params_default();
    p.clusters = 200;
    size_t len = vsaqem_arena_bytes(n, &p);
    CHECK(len > 0 && len < SIZE_MAX, "vsaqem_arena_bytes gave %zu", len);
    unsigned char *buf = malloc(len + 1), *again = malloc(len + 1);
    vsaqem_mesh m, m2;

    /* A sphere far from the origin, from a buffer that does not start on an
     * 8-byte boundary: closed, genus 0, in the caller's coordinates. */
    int32_t s = vsaqem_reconstruct(buf + 1, len, pts, n, NULL, &p, &m);
    CHECK(s == VSAQEM_OK, "status %d: %s", s, m.message);
    if (s == VSAQEM_OK) {
        CHECK(closed_with_genus(&m, 0), "V %zu F %zu boundary %u components %u",
              m.vertex_count, m.triangle_count, m.boundary_edges, m.components);
        CHECK(m.vertex_count >= 150 && m.vertex_count <= 600, "V %zu", m.vertex_count);
        double worst = 0;
        for (size_t i = 0; i < m.vertex_count; i++) {
            const float *q = m.vertices + 3 * i;
            double d = sqrt(pow(q[0] - centre[0], 2) + pow(q[1] - centre[1], 2) +
                            pow(q[2] - centre[2], 2));
            worst = fmax(worst, fabs(d - 2.5));
        }
        CHECK(worst < 0.05, "a vertex is %g off the sphere", worst);
        CHECK(m.max_distance > 0 && m.max_distance < 0.05, "max distance %g", m.max_distance);
        CHECK(m.buffer_peak <= len && m.buffer_needed == len, "peak %zu needed %zu of %zu",
              m.buffer_peak, m.buffer_needed, len);
        CHECK(m.message[0] == 0, "message on success: %s", m.message);
        printf("sphere: %zu points -> %zu vertices, %zu triangles, closed, genus 0; "
               "max distance %.4g; buffer %zu bytes, peak %zu\n",
               n, m.vertex_count, m.triangle_count, m.max_distance, len, m.buffer_peak);

        /* Deterministic: another run, in another, smaller buffer (core
         * checks what this cloud needs as it goes), gives the same bytes. */
        size_t small = len / 5 * 4;
        int32_t s2 = vsaqem_reconstruct(again, small, pts, n, NULL, &p, &m2);
        CHECK(s2 == VSAQEM_OK && m2.vertex_count == m.vertex_count &&
                  m2.triangle_count == m.triangle_count &&
                  !memcmp(m2.vertices, m.vertices, 12 * m.vertex_count) &&
                  !memcmp(m2.triangles, m.triangles, 12 * m.triangle_count),
              "a second run, in %zu bytes, differs: status %d %s", small, s2, m2.message);
    }

    /* Every point stored three times: merged, the same mesh as stored once. */
    float *thrice = malloc(9 * n * sizeof *thrice);
    for (size_t c = 0; c < 3; c++) memcpy(thrice + 3 * n * c, pts, 3 * n * sizeof *pts);
    size_t len3x = vsaqem_arena_bytes(3 * n, &p);
    unsigned char *buf3x = malloc(len3x);
    s = vsaqem_reconstruct(buf, len, pts, n, NULL, &p, &m);
    int32_t s3 = vsaqem_reconstruct(buf3x, len3x, thrice, 3 * n, NULL, &p, &m2);
    CHECK(s == VSAQEM_OK && s3 == VSAQEM_OK && m2.duplicates_merged == 2 * n &&
              m2.points_used == n && m2.vertex_count == m.vertex_count &&
              m2.triangle_count == m.triangle_count &&
              !memcmp(m2.vertices, m.vertices, 12 * m.vertex_count) &&
              !memcmp(m2.triangles, m.triangles, 12 * m.triangle_count),
          "stored three times: status %d, %zu merged, %zu used: %s", s3, m2.duplicates_merged,
          m2.points_used, m2.message);
    free(buf3x);
    free(thrice);

    /* Normals given: still a closed sphere. */
    float *nrm = malloc(3 * n * sizeof *nrm);
    for (size_t i = 0; i < 3 * n; i++) nrm[i] = (pts[i] - centre[i % 3]) / 2.5f;
    s = vsaqem_reconstruct(buf, len, pts, n, nrm, &p, &m);
    CHECK(s == VSAQEM_OK && closed_with_genus(&m, 0), "with normals: status %d %s", s, m.message);

    /* Errors: a status, the reason in the message, no mesh. */
    s = vsaqem_reconstruct(buf, len, NULL, n, NULL, &p, &m);
    CHECK(s == VSAQEM_NULL_POINTER && strstr(m.message, "points"), "%d %s", s, m.message);
    CHECK(m.vertices == NULL && m.triangles == NULL, "a mesh on error");
    s = vsaqem_reconstruct(buf, 40000, pts, n, NULL, &p, &m);
    CHECK(s == VSAQEM_BUFFER_TOO_SMALL && strstr(m.message, "vsaqem_arena_bytes"), "%d %s", s,
          m.message);
    s = vsaqem_reconstruct(buf, 300000, pts, n, NULL, &p, &m);
    CHECK(s == VSAQEM_ARENA_TOO_SMALL && strstr(m.message, "needs"), "%d %s", s, m.message);
    pts[3 * 17 + 1] = NAN;
    s = vsaqem_reconstruct(buf, len, pts, n, NULL, &p, &m);
    CHECK(s == VSAQEM_NON_FINITE && strstr(m.message, "point 17: coordinate y"), "%d %s", s,
          m.message);
    pts[3 * 17 + 1] = 0.0f;
    vsaqem_params bad = p;
    bad.densify = 2.0f;
    s = vsaqem_reconstruct(buf, len, pts, n, NULL, &bad, &m);
    CHECK(s == VSAQEM_BAD_PARAMETER && strstr(m.message, "densify"), "%d %s", s, m.message);
    CHECK(vsaqem_arena_bytes(n, &bad) == SIZE_MAX, "arena bytes of bad params");
    bad = p;
    bad.partition = 7;
    s = vsaqem_reconstruct(buf, len, pts, n, NULL, &bad, &m);
    CHECK(s == VSAQEM_BAD_PARAMETER && strstr(m.message, "partition"), "%d %s", s, m.message);
    bad = p;
    bad.k = 40;
    s = vsaqem_reconstruct(buf, len, pts, n, NULL, &bad, &m);
    CHECK(s == VSAQEM_BAD_NEIGHBOURS, "k = 40: %d %s", s, m.message);
    bad = p;
    bad.clusters = 3;
    bad.max_clusters = 3;
    size_t len3 = vsaqem_arena_bytes(n, &bad);
    CHECK(len3 <= len, "3 clusters need more than 200");
    s = vsaqem_reconstruct(buf, len, pts, n, NULL, &bad, &m);
    CHECK(s != VSAQEM_OK && m.vertices == NULL, "3 clusters gave a mesh: %d", s);
    /* Points on one plane. */
    for (size_t i = 0; i < n; i++) pts[3 * i + 2] = 5.0f;
    s = vsaqem_reconstruct(buf, len, pts, n, NULL, &p, &m);
    CHECK(s == VSAQEM_DEGENERATE && strstr(m.message, "plane"), "%d %s", s, m.message);
    s = vsaqem_reconstruct(buf, len, pts, 3, NULL, &p, &m);
    CHECK(s == VSAQEM_TOO_FEW_POINTS || s == VSAQEM_BAD_NEIGHBOURS, "3 points: %d %s", s,
          m.message);
    CHECK(vsaqem_reconstruct(buf, len, pts, n, NULL, &p, NULL) == VSAQEM_NULL_POINTER,
          "null out");
    CHECK(!strcmp(vsaqem_error_message(VSAQEM_OK), "ok") &&
              !strcmp(vsaqem_error_message(-5), "unknown status"),
          "error messages");
    free(nrm);
    free(buf);
    free(again);
    free(pts);
}

/* The vertices (x y z floats first of each) of a binary little-endian PLY. */
static float *read_ply(const char *path, size_t *n) {
    FILE *f = fopen(path, "rb");
    if (!f) return perror(path), NULL;
    char line[256];
    size_t count = 0, stride = 0;
    int in_vertex = 0, binary = 0;
    while (fgets(line, sizeof line, f)) {
        if (!strncmp(line, "format binary_little_endian", 27)) binary = 1;
        if (sscanf(line, "element vertex %zu", &count) == 1) in_vertex = 1;
        else if (!strncmp(line, "element", 7)) in_vertex = 0;
        if (in_vertex && !strncmp(line, "property float", 14)) stride += 4;
        else if (in_vertex && !strncmp(line, "property", 8)) {
            fprintf(stderr, "%s: only float vertex properties are read here\n", path);
            return fclose(f), NULL;
        }
        if (!strncmp(line, "end_header", 10)) break;
    }
    if (!binary || count == 0 || stride < 12) {
        fprintf(stderr, "%s: not a binary little-endian PLY with float x y z\n", path);
        return fclose(f), NULL;
    }
    float *p = malloc(3 * count * sizeof *p);
    unsigned char *row = malloc(stride);
    for (size_t i = 0; i < count; i++) {
        if (fread(row, stride, 1, f) != 1) {
            fprintf(stderr, "%s: vertex %zu: file ends\n", path, i);
            return fclose(f), free(row), free(p), NULL;
        }
        memcpy(p + 3 * i, row, 12);
    }
    fclose(f);
    free(row);
    *n = count;
    return p;
}

static int write_ply(const char *path, const vsaqem_mesh *m) {
    FILE *f = fopen(path, "wb");
    if (!f) return perror(path), 0;
    fprintf(f,
            "ply\nformat binary_little_endian 1.0\nelement vertex %zu\nproperty float x\n"
            "property float y\nproperty float z\nelement face %zu\n"
            "property list uchar int vertex_indices\nend_header\n",
            m->vertex_count, m->triangle_count);
    fwrite(m->vertices, 12, m->vertex_count, f);
    for (size_t i = 0; i < m->triangle_count; i++) {
        unsigned char three = 3;
        fwrite(&three, 1, 1, f);
        fwrite(m->triangles + 3 * i, 4, 3, f);
    }
    return fclose(f) == 0;
}

static int cloud(const char *in, const char *out, unsigned clusters) {
    size_t n = 0;
    float *pts = read_ply(in, &n);
    if (!pts) return 1;
    vsaqem_params p = vsaqem_params_default();
    if (clusters) p.clusters = clusters;
    size_t len = vsaqem_arena_bytes(n, &p);
    void *buf = malloc(len);
    if (!buf) return fprintf(stderr, "%zu bytes: out of memory\n", len), 1;
    vsaqem_mesh m;
    clock_t t0 = clock();
    int32_t s = vsaqem_reconstruct(buf, len, pts, n, NULL, &p, &m);
    double secs = (double)(clock() - t0) / CLOCKS_PER_SEC;
    if (s != VSAQEM_OK) {
        fprintf(stderr, "%s: %s (status %d: %s)\n", in, m.message, s, vsaqem_error_message(s));
        return 1;
    }
    printf("%s: %zu points (%zu removed by cleaning) -> %zu vertices, %zu triangles, "
           "%u boundary edges, %u components; max distance %.3f%% of the diagonal; "
           "buffer %zu bytes (%.1f per point), peak %zu; %.2f s\n",
           in, n, m.points_removed, m.vertex_count, m.triangle_count, m.boundary_edges,
           m.components, 100.0 * m.max_distance / m.diagonal, len, (double)len / n,
           m.buffer_peak, secs);
    CHECK(m.boundary_edges == 0 && m.components == 1, "not closed");
    if (out && !write_ply(out, &m)) return 1;
    free(buf);
    free(pts);
    return failures != 0;
}

int main(int argc, char **argv) {
    if (argc > 1)
        return cloud(argv[1], argc > 2 ? argv[2] : NULL,
                     argc > 3 ? (unsigned)strtoul(argv[3], NULL, 10) : 0);
    sphere_checks();
    if (failures) fprintf(stderr, "%d checks failed\n", failures);
    else printf("every check holds\n");
    return failures != 0;
}
