/* The unit block [-0.5, 0.5]^3 cut into n x n x n cubes of six tets each, as plain arrays for
 * td_world_init: the mesh tetradrill calls `builtin:block:N`, written here in C, with its
 * region labels (an outer shell one cube thick and the core inside it).
 *
 * Nodes run along x, then y, then z; each cube gives the six tets along the six axis paths
 * from its low corner to its high one, each turned to positive orientation. Build with
 * -ffp-contract=off so the positions are the same floats the core computes (a fused
 * multiply-add would round differently). */
#ifndef TETRADRILL_EXAMPLE_BLOCK_H
#define TETRADRILL_EXAMPLE_BLOCK_H

#include <stdint.h>

/* Nodes of an n-block. */
static inline uint32_t block_nodes(uint32_t n) { return (n + 1) * (n + 1) * (n + 1); }

/* Tets of an n-block. */
static inline uint32_t block_tets(uint32_t n) { return 6 * n * n * n; }

/* Six times the signed volume of the tet (a, b, c, d), in double. */
static inline double block_det6(const float *p, const uint32_t *t) {
    const float *a = p + 3 * t[0], *b = p + 3 * t[1], *c = p + 3 * t[2], *d = p + 3 * t[3];
    double u[3], v[3], w[3];
    for (int k = 0; k < 3; k++) {
        u[k] = (double)b[k] - a[k];
        v[k] = (double)c[k] - a[k];
        w[k] = (double)d[k] - a[k];
    }
    return u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) +
           u[2] * (v[0] * w[1] - v[1] * w[0]);
}

/* Writes the n-block: 3 * block_nodes(n) floats to `positions`, 4 * block_tets(n) node
 * indices to `tets`. */
static inline void block_write(uint32_t n, float *positions, uint32_t *tets) {
    static const int paths[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    const uint32_t m = n + 1;
    const float edge = 1.0f / (float)n;
    for (uint32_t k = 0; k < m; k++)
        for (uint32_t j = 0; j < m; j++)
            for (uint32_t i = 0; i < m; i++) {
                float *p = positions + 3 * (i + m * (j + m * k));
                p[0] = -0.5f + (float)i * edge;
                p[1] = -0.5f + (float)j * edge;
                p[2] = -0.5f + (float)k * edge;
            }
    uint32_t c = 0;
    for (uint32_t k = 0; k < n; k++)
        for (uint32_t j = 0; j < n; j++)
            for (uint32_t i = 0; i < n; i++)
                for (int q = 0; q < 6; q++) {
                    uint32_t at[3] = {i, j, k};
                    uint32_t *t = tets + 4 * c;
                    t[0] = i + m * (j + m * k);
                    for (int s = 0; s < 3; s++) {
                        at[paths[q][s]] += 1;
                        t[s + 1] = at[0] + m * (at[1] + m * at[2]);
                    }
                    if (block_det6(positions, t) < 0.0) {
                        uint32_t x = t[2];
                        t[2] = t[3];
                        t[3] = x;
                    }
                    c++;
                }
}

/* Region label of the tets of the block's outer layer of cubes. */
#define BLOCK_SHELL 1
/* Region label of the tets of the cubes inside the shell (none when n <= 2). */
#define BLOCK_CORE 2

/* Writes the region label of each tet (block_write's order, six per cube) to `labels`,
 * block_tets(n) of them: BLOCK_SHELL for the cubes on the block's boundary, BLOCK_CORE for the
 * others. */
static inline void block_labels(uint32_t n, int32_t *labels) {
    uint32_t c = 0;
    for (uint32_t k = 0; k < n; k++)
        for (uint32_t j = 0; j < n; j++)
            for (uint32_t i = 0; i < n; i++) {
                const int shell = i == 0 || j == 0 || k == 0 || i + 1 == n || j + 1 == n || k + 1 == n;
                for (int q = 0; q < 6; q++)
                    labels[c++] = shell ? BLOCK_SHELL : BLOCK_CORE;
            }
}

#endif
