/* The host's `builtin:firmware` scenario as C interface parameters: a burr of radius 0.1
 * drilling the unit block of 4 x 4 x 4 cubes along the demo path, sized for a
 * microcontroller's RAM. Every setting is the host scenario's (host-runner/src/scenario),
 * written as the host derives it: doubles converted to float. Used by the Cortex-M example and
 * by the two-thread program. */
#ifndef TETRADRILL_EXAMPLE_FIRMWARE_PARAMS_H
#define TETRADRILL_EXAMPLE_FIRMWARE_PARAMS_H

#include "tetradrill.h"

/* The block's cubes a side. */
#define FIRMWARE_BLOCK_N 4

/* Fills `*p` for the firmware scenario on a mesh of `nodes` and `tets`; the status of
 * td_params_default. */
static inline td_status firmware_params(uint32_t nodes, uint32_t tets, td_params *p) {
    td_status st = td_params_default(nodes, tets, p);
    if (st != TD_OK)
        return st;
    /* The demo's tool and forces ... */
    p->radius = (float)0.1;
    p->reach = 0.5f * p->radius;
    p->stiffness = (float)200.0;
    p->damping = (float)0.5;
    p->max_force = (float)8.0;
    p->dt = (float)1e-3;
    p->switch_time = (float)(16.0 / 1000.0);
    p->servo_lag = 1; /* the RTIC release rule: the servo first, then the step it releases */
    p->min_area = (float)0.0;
    /* ... with its own limits: depth 4, 300 work units a tick, 64 contact nodes, separate
     * bounds, a 20,000-node arena and a 16,384-item deque; candidates and query cells at the
     * core's defaults (what `replay` sizes for this burr on this mesh). */
    p->max_depth = 4;
    p->budget_per_tick = 300;
    p->contact_search_nodes = 64;
    p->tick_budget = 0;
    p->hierarchy_capacity = 20000;
    p->pending_capacity = 16384;
    p->candidate_capacity = 1024;
    p->max_cells = 4096;
    /* No materials in this scenario: the mesh goes in without labels, one region. */
    p->region_capacity = 1;
    return TD_OK;
}

#endif
