/* Replays tetradrill's demo with a drill through the C interface: a burr on a shaft, force
 * and torque out.
 *
 * The run is `tetradrill replay --scenario builtin:demo --tool drill:0.1:0.6:0.03`: the demo's
 * block (a hard shell, label 1, round a soft core, label 2) and scripted path, the burr of
 * radius 0.1 on a shaft reaching 0.6 from its centre, 0.03 in radius (18 passive points that
 * push back but never erode). The script's poses have no rotation: the identity, the shaft
 * along +z. Each tick is `td_world_tick_pose`: the drill's simulation step (the burr drilled,
 * the shaft's points tracked), then the force of the burr and the shaft together and the
 * shaft's moment about the burr's centre. Prints `force_digest=HEX` (equal to the host's,
 * scripts/c-example.sh --tools checks it), `removed_by_region.LABEL=V`, the shaft's figures
 * (`shaft.near_ticks=N` ..., the host's `shaft` in its JSON) and `torque_digest=HEX`.
 *
 * The settings are the host scenario's, doubles converted to float as the host does. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "block.h"
#include "tetradrill.h"

#define BLOCK_N 8

static void check(td_status st, const char *what) {
    if (st != TD_OK) {
        fprintf(stderr, "drill_demo: %s: %s (status %d)\n", what, td_status_name((int32_t)st), (int)st);
        exit(1);
    }
}

int main(void) {
    const uint32_t nodes = block_nodes(BLOCK_N), tets = block_tets(BLOCK_N);
    float *positions = malloc(sizeof(float) * 3 * nodes);
    uint32_t *tet_nodes = malloc(sizeof(uint32_t) * 4 * tets);
    int32_t *labels = malloc(sizeof(int32_t) * tets);
    if (!positions || !tet_nodes || !labels) {
        fprintf(stderr, "drill_demo: out of memory for the mesh arrays\n");
        return 1;
    }
    block_write(BLOCK_N, positions, tet_nodes);
    block_labels(BLOCK_N, labels);

    td_params p;
    check(td_params_default(nodes, tets, &p), "td_params_default");
    /* builtin:demo's settings, as examples/c/replay_demo.c sets them; the burr is the drill's. */
    p.radius = (float)0.1;
    p.reach = 0.5f * p.radius;
    p.stiffness = (float)200.0;
    p.damping = (float)0.5;
    p.max_force = (float)8.0;
    p.dt = (float)1e-3;
    p.switch_time = (float)(16.0 / 1000.0);
    p.max_depth = 5;
    p.min_area = (float)0.0;
    p.budget_per_tick = 11000;
    p.tick_budget = 16500;
    p.contact_search_nodes = 4096;
    p.hierarchy_capacity = 1u << 20;
    p.candidate_capacity = 3072; /* `replay` sizes the list for the drill (it prints it) */
    p.pending_capacity = 1u << 15;
    p.max_cells = 4096;
    p.region_capacity = 2;

    size_t size = 0, align = 0;
    check(td_world_size(&p, &size, &align), "td_world_size");
    void *mem = aligned_alloc(align, (size + align - 1) / align * align);
    if (!mem) {
        fprintf(stderr, "drill_demo: out of memory for the world (%zu bytes)\n", size);
        return 1;
    }
    td_world *world = NULL;
    uint32_t bad = 0;
    td_status st = td_world_init(mem, size, &p, positions, tet_nodes, labels, &world, &bad);
    if (st == TD_ERR_MESH || st == TD_ERR_LABEL)
        fprintf(stderr, "drill_demo: mesh refused at item %u\n", (unsigned)bad);
    check(st, "td_world_init");
    check(td_world_set_region(world, BLOCK_SHELL, (float)300.0, (float)2.0, (float)300.0),
          "td_world_set_region (shell)");
    check(td_world_set_region(world, BLOCK_CORE, (float)120.0, (float)0.5, (float)150.0),
          "td_world_set_region (core)");
    /* tool = "drill:0.1:0.6:0.03": the burr's radius is p.radius; the shaft's length and
     * radius here. Before the first step and before the servo runs. */
    check(td_world_set_drill(world, (float)0.6, (float)0.03), "td_world_set_drill");

    const uint32_t ticks = td_demo_ticks();
    float torque_max = 0.0f;
    for (uint32_t i = 0; i < ticks; i++) {
        td_pose pose = {.rotation = {.w = 1.0f, .x = 0.0f, .y = 0.0f, .z = 0.0f}};
        td_vec3 force, torque;
        uint32_t buttons = 0;
        check(td_demo_pose(i, &pose.position, &buttons), "td_demo_pose");
        check(td_world_tick_pose(world, pose, buttons, &force, &torque), "td_world_tick_pose");
        float t2 = torque.x * torque.x + torque.y * torque.y + torque.z * torque.z;
        if (t2 > torque_max)
            torque_max = t2;
    }

    td_counters c;
    check(td_world_counters(world, &c), "td_world_counters");
    td_servo *servo = NULL;
    td_servo_counts sc;
    td_tool_counts tc;
    td_shaft_counts shaft;
    check(td_world_servo(world, &servo), "td_world_servo");
    check(td_servo_counters(servo, &sc), "td_servo_counters");
    check(td_servo_tool_counters(servo, &tc), "td_servo_tool_counters");
    check(td_world_shaft(world, &shaft), "td_world_shaft");
    printf("world_bytes=%zu\n", size);
    printf("ticks=%llu\n", (unsigned long long)sc.servo_ticks);
    printf("contact_ticks=%llu\n", (unsigned long long)sc.contact_ticks);
    printf("removed_volume=%.6f\n", c.removed_volume);
    for (uint32_t i = 0; i < c.region_count; i++) {
        td_region r;
        check(td_world_region_at(world, i, &r), "td_world_region_at");
        printf("removed_by_region.%d=%.6f\n", (int)r.label, r.removed_volume);
    }
    printf("shaft.passive_points=%u\n", (unsigned)shaft.passive_points);
    printf("shaft.near_ticks=%llu\n", (unsigned long long)shaft.near_ticks);
    printf("shaft.held_ticks=%llu\n", (unsigned long long)shaft.held_ticks);
    printf("shaft.held_max=%u\n", (unsigned)shaft.held_max);
    printf("torque_max=%.6f\n", sqrt((double)torque_max));
    printf("torque_digest=%016llx\n", (unsigned long long)tc.torque_digest);
    printf("force_digest=%016llx\n", (unsigned long long)sc.force_digest);

    free(mem);
    free(labels);
    free(tet_nodes);
    free(positions);
    return 0;
}
