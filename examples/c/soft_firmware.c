/* The firmware scenario with its block soft, through the C interface on the host: the world of
 * `builtin:firmware` made deformable (td_params.deformable) and the soft block of soft_block.h
 * linked to it, the demo path replayed tick by tick as the Cortex-M4 program runs it (the servo
 * force from the previous tick's contact, then the step: td_params.servo_lag 1), each tick's
 * force handed to the link after the step. Prints the force digest, the link's figures and the
 * dent; scripts/c-example.sh --cortex-m compares the digest with the same set-up's on the
 * Cortex-M4 (cortex_m/main.c built with SOFT_BODY). */
#include <stdio.h>
#include <stdlib.h>

#include "block.h"
#include "firmware_params.h"
#include "soft_block.h"

static void check(td_status st, const char *what) {
    if (st != TD_OK) {
        fprintf(stderr, "soft_firmware: %s: %s (status %d)\n", what, td_status_name((int32_t)st),
                (int)st);
        exit(1);
    }
}

static void *alloc(size_t size) {
    void *p = aligned_alloc(64, (size + 63) / 64 * 64);
    if (!p) {
        fprintf(stderr, "soft_firmware: out of memory\n");
        exit(1);
    }
    return p;
}

int main(void) {
    const uint32_t n = FIRMWARE_BLOCK_N, nodes = block_nodes(n), tets = block_tets(n);
    float *xyz = malloc(sizeof(float) * 3 * nodes);
    uint32_t *tet_nodes = malloc(sizeof(uint32_t) * 4 * tets);
    if (!xyz || !tet_nodes) {
        fprintf(stderr, "soft_firmware: out of memory\n");
        return 1;
    }
    block_write(n, xyz, tet_nodes);
    td_params p;
    check(firmware_params(nodes, tets, &p), "td_params_default");
    p.deformable = 1;
    size_t size = 0, align = 0;
    check(td_world_size(&p, &size, &align), "td_world_size");
    td_world *world;
    uint32_t bad = 0;
    check(td_world_init(alloc(size), size, &p, xyz, tet_nodes, NULL, &world, &bad),
          "td_world_init");
    printf("world_bytes=%zu\n", size);
    size_t soft_len = 0, link_len = 0;
    check(td_soft_size(nodes, tets, &soft_len, &align), "td_soft_size");
    check(td_link_size(nodes, &link_len, &align), "td_link_size");
    td_soft *body;
    td_link *link;
    uint32_t held = 0;
    check(soft_block_init(world, alloc(soft_len), soft_len, alloc(link_len), link_len, xyz, nodes,
                          tet_nodes, tets, &body, &link, &held),
          "soft_block_init");
    printf("soft_bytes=%zu\nlink_bytes=%zu\nheld=%u\n", soft_len, link_len, held);

    const uint32_t ticks = td_demo_ticks();
    uint32_t most = 0;
    for (uint32_t i = 0; i < ticks; i++) {
        td_vec3 pose, force;
        uint32_t buttons = 0;
        td_link_report r;
        check(td_demo_pose(i, &pose, &buttons), "td_demo_pose");
        check(td_world_tick(world, pose, buttons, &force), "td_world_tick");
        check(td_link_tick(link, world, body, force, &r), "td_link_tick");
        most = r.units > most ? r.units : most;
    }
    td_link_counts lc;
    td_servo *servo;
    td_servo_counts sc;
    check(td_link_counters(link, &lc), "td_link_counters");
    check(td_world_servo(world, &servo), "td_world_servo");
    check(td_servo_counters(servo, &sc), "td_servo_counters");
    printf("ticks=%llu\n", (unsigned long long)sc.servo_ticks);
    printf("soft_steps=%u\nunits_per_tick=%u\nunits_most=%u\nlate=%u\n", lc.steps,
           lc.units_per_tick, most, lc.late);
    printf("max_displacement_um=%u\n", (unsigned)(lc.max_displacement * 1e6f));
    printf("force_digest=%016llx\n", (unsigned long long)sc.force_digest);
    return 0;
}
