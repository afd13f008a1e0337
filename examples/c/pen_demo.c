/* Touches tetradrill's demo block with a tet-mesh tool (the pen) through the C interface:
 * force and torque out.
 *
 * The run is `tetradrill replay --scenario builtin:demo --tool mesh:builtin:block:2
 * --tool-scale 0.2`: the demo's block of 8 x 8 x 8 cubes, and as the tool the block of 2 x 2 x 2
 * cubes scaled to an edge of 0.2 (27 nodes, 48 tets, its tip, the origin, at its centre),
 * along the demo's path with no rotation, contact only. Each tick is `td_pen_tick`: the
 * contact pass (the pen's nodes in the block and the block's in the pen, their consistent
 * penetration depths), then the force and the torque about the tip from them. Prints
 * `force_digest=HEX` (the host's; scripts/c-example.sh --tools checks it), the pass's figures
 * as `pen.NAME=V` (the host's `pen` in its JSON) and `torque_digest=HEX`.
 *
 * The pen's memory is sized in two steps: `td_pen_size` gives the part the counts give, in
 * which `td_pen_init` builds the meshes and measures the rest; told TD_ERR_TOO_SMALL with the
 * bytes needed, the program allocates them and calls it again. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "block.h"
#include "tetradrill.h"

#define BLOCK_N 8
#define PEN_N 2
#define PEN_SCALE 0.2

static void check(td_status st, const char *what) {
    if (st != TD_OK) {
        fprintf(stderr, "pen_demo: %s: %s (status %d)\n", what, td_status_name((int32_t)st), (int)st);
        exit(1);
    }
}

int main(void) {
    const uint32_t nodes = block_nodes(BLOCK_N), tets = block_tets(BLOCK_N);
    const uint32_t pen_nodes = block_nodes(PEN_N), pen_tets = block_tets(PEN_N);
    float *positions = malloc(sizeof(float) * 3 * nodes);
    uint32_t *tet_nodes = malloc(sizeof(uint32_t) * 4 * tets);
    float *pen_positions = malloc(sizeof(float) * 3 * pen_nodes);
    uint32_t *pen_tet_nodes = malloc(sizeof(uint32_t) * 4 * pen_tets);
    if (!positions || !tet_nodes || !pen_positions || !pen_tet_nodes) {
        fprintf(stderr, "pen_demo: out of memory for the mesh arrays\n");
        return 1;
    }
    block_write(BLOCK_N, positions, tet_nodes);
    /* The pen as the host reads `builtin:block:2` at --tool-scale 0.2: each coordinate made a
     * double, scaled, made a float again. */
    block_write(PEN_N, pen_positions, pen_tet_nodes);
    for (uint32_t i = 0; i < 3 * pen_nodes; i++)
        pen_positions[i] = (float)((double)pen_positions[i] * PEN_SCALE);

    td_pen_params p;
    check(td_pen_params_default(nodes, tets, pen_nodes, pen_tets, &p), "td_pen_params_default");
    /* builtin:demo's forces (td_pen_params_default's are the same: 200 N per unit, 0.5 N s
     * per unit, 8 N, 1 kHz); traced depths with the crossings reused, as the host's. */
    p.stiffness = (float)200.0;
    p.damping = (float)0.5;
    p.max_force = (float)8.0;
    p.dt = (float)1e-3;

    size_t size = 0, align = 0, needed = 0;
    check(td_pen_size(&p, &size, &align), "td_pen_size");
    const size_t counts_part = size;
    void *mem = aligned_alloc(align, (size + align - 1) / align * align);
    if (!mem) {
        fprintf(stderr, "pen_demo: out of memory (%zu bytes)\n", size);
        return 1;
    }
    td_pen *pen = NULL;
    uint32_t bad = 0;
    td_status st = td_pen_init(mem, size, &p, positions, tet_nodes, pen_positions, pen_tet_nodes,
                               &pen, &needed, &bad);
    if (st == TD_ERR_TOO_SMALL) {
        /* The meshes' shapes measured: allocate what they need and build again. */
        free(mem);
        size = needed;
        mem = aligned_alloc(align, (size + align - 1) / align * align);
        if (!mem) {
            fprintf(stderr, "pen_demo: out of memory (%zu bytes)\n", size);
            return 1;
        }
        st = td_pen_init(mem, size, &p, positions, tet_nodes, pen_positions, pen_tet_nodes,
                         &pen, &needed, &bad);
    }
    if (st == TD_ERR_MESH)
        fprintf(stderr, "pen_demo: mesh refused at item %u (%s)\n", (unsigned)(bad & ~TD_PEN_ITEM),
                bad & TD_PEN_ITEM ? "the pen" : "the object");
    check(st, "td_pen_init");

    const uint32_t ticks = td_demo_ticks();
    double torque_max = 0.0;
    for (uint32_t i = 0; i < ticks; i++) {
        td_pose pose = {.rotation = {.w = 1.0f, .x = 0.0f, .y = 0.0f, .z = 0.0f}};
        td_vec3 force, torque;
        uint32_t buttons = 0;
        check(td_demo_pose(i, &pose.position, &buttons), "td_demo_pose");
        check(td_pen_tick(pen, pose, &force, &torque), "td_pen_tick");
        double t = sqrt((double)torque.x * torque.x + (double)torque.y * torque.y +
                        (double)torque.z * torque.z);
        if (t > torque_max)
            torque_max = t;
    }

    td_pen_counts c;
    td_pen_servo *servo = NULL;
    td_pen_servo_counts sc;
    check(td_pen_counters(pen, &c), "td_pen_counters");
    check(td_pen_servo_handle(pen, &servo), "td_pen_servo_handle");
    check(td_pen_servo_counters(servo, &sc), "td_pen_servo_counters");
    printf("pen_bytes=%llu\n", (unsigned long long)c.bytes);
    printf("pen_bytes_before_measuring=%zu\n", counts_part);
    printf("ticks=%llu\n", (unsigned long long)sc.servo_ticks);
    printf("contact_ticks=%llu\n", (unsigned long long)sc.contact_ticks);
    printf("pen.pen_collisions_max=%u\n", (unsigned)c.pen_collisions_max);
    printf("pen.object_collisions_max=%u\n", (unsigned)c.object_collisions_max);
    printf("pen.unreached=%llu\n", (unsigned long long)c.unreached);
    printf("pen.clamped_ticks=%llu\n", (unsigned long long)sc.clamped_ticks);
    printf("pen.saturated_ticks=%llu\n", (unsigned long long)c.saturated_passes);
    printf("pen.border_edges=%llu\n", (unsigned long long)c.border_edges);
    printf("pen.reused_crossings=%llu\n", (unsigned long long)c.reused_crossings);
    printf("pen.passes=%llu\n", (unsigned long long)c.passes);
    printf("pen.servo_short_ticks=%llu\n", (unsigned long long)sc.short_ticks);
    printf("torque_max=%.6f\n", torque_max);
    printf("torque_digest=%016llx\n", (unsigned long long)sc.torque_digest);
    printf("force_digest=%016llx\n", (unsigned long long)sc.force_digest);

    free(mem);
    free(pen_tet_nodes);
    free(pen_positions);
    free(tet_nodes);
    free(positions);
    return 0;
}
