/* The set-up of tetradrill's demo (`tetradrill replay --scenario builtin:demo`) for the C
 * examples: the parameters of the scenario, its world in memory from aligned_alloc with the
 * block's mesh and labels, and its two materials.
 *
 * Every setting is the host scenario's, written the way the host derives it: the host parses
 * f64 and converts to f32, so the numbers below are doubles converted to float. Build with
 * -ffp-contract=off (block.h). */
#ifndef TETRADRILL_EXAMPLE_DEMO_H
#define TETRADRILL_EXAMPLE_DEMO_H

#include <stdio.h>
#include <stdlib.h>

#include "block.h"
#include "tetradrill.h"

#define BLOCK_N 8

/* Prints `what` and the status's line to stderr and exits 1 when `st` is not TD_OK. */
static inline void demo_check(td_status st, const char *what) {
    if (st != TD_OK) {
        fprintf(stderr, "demo: %s: %s (status %d)\n", what, td_status_name((int32_t)st), (int)st);
        exit(1);
    }
}

/* Sets up the demo's world in memory from aligned_alloc (its bytes in *size), or exits 1. */
static inline td_world *demo_world(size_t *size) {
    const uint32_t nodes = block_nodes(BLOCK_N), tets = block_tets(BLOCK_N);
    float *positions = malloc(sizeof(float) * 3 * nodes);
    uint32_t *tet_nodes = malloc(sizeof(uint32_t) * 4 * tets);
    int32_t *labels = malloc(sizeof(int32_t) * tets);
    if (!positions || !tet_nodes || !labels) {
        fprintf(stderr, "demo: out of memory for the mesh arrays\n");
        exit(1);
    }
    block_write(BLOCK_N, positions, tet_nodes);
    block_labels(BLOCK_N, labels);

    td_params p;
    demo_check(td_params_default(nodes, tets, &p), "td_params_default");
    /* The scenario builtin:demo (host-runner/src/scenario.rs, its defaults). */
    p.radius = (float)0.1;           /* tool = "sphere:0.1" */
    p.reach = 0.5f * p.radius;       /* the servo's extrapolation range: half the radius */
    p.stiffness = (float)200.0;
    p.damping = (float)0.5;
    p.max_force = (float)8.0;
    p.dt = (float)1e-3;              /* 1 kHz */
    p.switch_time = (float)(16.0 / 1000.0);
    p.max_depth = 5;
    p.min_area = (float)0.0;
    p.budget_per_tick = 11000;
    p.tick_budget = 16500;
    p.contact_search_nodes = 4096;
    /* The capacities `replay` sizes for this burr on this mesh (it prints them): the arena
     * and the candidate list; the deque and the query cells at the core's defaults. */
    p.hierarchy_capacity = 1u << 20;
    p.candidate_capacity = 1266;
    p.pending_capacity = 1u << 15;
    p.max_cells = 4096;
    p.region_capacity = 2; /* the shell and the core */

    size_t align = 0;
    demo_check(td_world_size(&p, size, &align), "td_world_size");
    /* aligned_alloc wants a size that is a multiple of the alignment. */
    void *mem = aligned_alloc(align, (*size + align - 1) / align * align);
    if (!mem) {
        fprintf(stderr, "demo: out of memory for the world (%zu bytes)\n", *size);
        exit(1);
    }
    td_world *world = NULL;
    uint32_t bad = 0;
    td_status st = td_world_init(mem, *size, &p, positions, tet_nodes, labels, &world, &bad);
    if (st == TD_ERR_MESH || st == TD_ERR_LABEL)
        fprintf(stderr, "demo: mesh refused at item %u\n", (unsigned)bad);
    demo_check(st, "td_world_init");
    /* The demo's materials (host-runner/src/scenario.rs, demo_regions): hardness in N s per
     * cubic unit, threshold in N, stiffness in N per unit. */
    demo_check(td_world_set_region(world, BLOCK_SHELL, (float)300.0, (float)2.0, (float)300.0),
               "td_world_set_region (shell)");
    demo_check(td_world_set_region(world, BLOCK_CORE, (float)120.0, (float)0.5, (float)150.0),
               "td_world_set_region (core)");
    /* The arrays are read only by td_world_init. */
    free(labels);
    free(tet_nodes);
    free(positions);
    return world;
}

#endif
