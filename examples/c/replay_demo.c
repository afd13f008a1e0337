/* Replays tetradrill's demo through the C interface and prints its force digest.
 *
 * The demo is `tetradrill replay --scenario builtin:demo`: a burr of radius 0.1 drilling the
 * unit block of 8 x 8 x 8 cubes along the scripted path, 6,001 ticks at 1 kHz. The block has
 * two materials: a hard, stiff shell (label 1) and a soft core (label 2), removed only while
 * the burr presses harder than their thresholds. Each tick is the simulation step then the
 * servo force at the same pose, whose magnitude presses the burr at the next step; the digest
 * of every force is printed as `force_digest=HEX`, equal to the host's (scripts/c-example.sh
 * checks it), and the volume removed from each region as `removed_by_region.LABEL=V`.
 *
 * Every setting is the host scenario's, written the way the host derives it: the host parses
 * f64 and converts to f32, so the numbers below are doubles converted to float. */
#include <stdio.h>
#include <stdlib.h>

#include "block.h"
#include "tetradrill.h"

#define BLOCK_N 8

/* Prints `what` and the status's line to stderr and exits 1 when `st` is not TD_OK. */
static void check(td_status st, const char *what) {
    if (st != TD_OK) {
        fprintf(stderr, "replay_demo: %s: %s (status %d)\n", what, td_status_name((int32_t)st), (int)st);
        exit(1);
    }
}

int main(void) {
    const uint32_t nodes = block_nodes(BLOCK_N), tets = block_tets(BLOCK_N);
    float *positions = malloc(sizeof(float) * 3 * nodes);
    uint32_t *tet_nodes = malloc(sizeof(uint32_t) * 4 * tets);
    int32_t *labels = malloc(sizeof(int32_t) * tets);
    if (!positions || !tet_nodes || !labels) {
        fprintf(stderr, "replay_demo: out of memory for the mesh arrays\n");
        return 1;
    }
    block_write(BLOCK_N, positions, tet_nodes);
    block_labels(BLOCK_N, labels);

    td_params p;
    check(td_params_default(nodes, tets, &p), "td_params_default");
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

    size_t size = 0, align = 0;
    check(td_world_size(&p, &size, &align), "td_world_size");
    /* aligned_alloc wants a size that is a multiple of the alignment. */
    void *mem = aligned_alloc(align, (size + align - 1) / align * align);
    if (!mem) {
        fprintf(stderr, "replay_demo: out of memory for the world (%zu bytes)\n", size);
        return 1;
    }
    td_world *world = NULL;
    uint32_t bad = 0;
    td_status st = td_world_init(mem, size, &p, positions, tet_nodes, labels, &world, &bad);
    if (st == TD_ERR_MESH || st == TD_ERR_LABEL)
        fprintf(stderr, "replay_demo: mesh refused at item %u\n", (unsigned)bad);
    check(st, "td_world_init");
    /* The demo's materials (host-runner/src/scenario.rs, demo_regions): hardness in N s per
     * cubic unit, threshold in N, stiffness in N per unit. */
    check(td_world_set_region(world, BLOCK_SHELL, (float)300.0, (float)2.0, (float)300.0),
          "td_world_set_region (shell)");
    check(td_world_set_region(world, BLOCK_CORE, (float)120.0, (float)0.5, (float)150.0),
          "td_world_set_region (core)");

    const uint32_t ticks = td_demo_ticks();
    for (uint32_t i = 0; i < ticks; i++) {
        td_vec3 pose, force;
        uint32_t buttons = 0;
        check(td_demo_pose(i, &pose, &buttons), "td_demo_pose");
        check(td_world_tick(world, pose, buttons, &force), "td_world_tick");
    }

    td_counters c;
    check(td_world_counters(world, &c), "td_world_counters");
    td_servo *servo = NULL;
    td_servo_counts sc;
    check(td_world_servo(world, &servo), "td_world_servo");
    check(td_servo_counters(servo, &sc), "td_servo_counters");
    printf("world_bytes=%zu\n", size);
    printf("ticks=%llu\n", (unsigned long long)sc.servo_ticks);
    printf("contact_ticks=%llu\n", (unsigned long long)sc.contact_ticks);
    printf("removed_volume=%.6f\n", c.removed_volume);
    printf("hierarchy_nodes=%llu\n", (unsigned long long)c.hierarchy_nodes);
    printf("visible_faces=%u\n", (unsigned)c.visible_faces);
    printf("saturations=%u (hash %u, candidates %u, arena %u, pending %u, contact %u)\n",
           (unsigned)c.sat_total, (unsigned)c.sat_hash, (unsigned)c.sat_candidates,
           (unsigned)c.sat_arena, (unsigned)c.sat_pending, (unsigned)c.sat_contact);
    for (uint32_t i = 0; i < c.region_count; i++) {
        td_region r;
        check(td_world_region_at(world, i, &r), "td_world_region_at");
        printf("removed_by_region.%d=%.6f\n", (int)r.label, r.removed_volume);
    }
    printf("force_digest=%016llx\n", (unsigned long long)sc.force_digest);

    /* Nothing to tear down in the world: its memory is simply given back. */
    free(mem);
    free(labels);
    free(tet_nodes);
    free(positions);
    return 0;
}
