/* Replays tetradrill's demo through the C interface and prints its force digest.
 *
 * The demo is `tetradrill replay --scenario builtin:demo`: a burr of radius 0.1 drilling the
 * unit block of 8 x 8 x 8 cubes along the scripted path, 6,001 ticks at 1 kHz. The block has
 * two materials: a hard, stiff shell (label 1) and a soft core (label 2), removed only while
 * the burr presses harder than their thresholds. Each tick is the simulation step then the
 * servo force at the same pose, whose magnitude presses the burr at the next step; the digest
 * of every force is printed as `force_digest=HEX`, equal to the host's (scripts/c-example.sh
 * checks it), and the volume removed from each region as `removed_by_region.LABEL=V`.
 * The world's set-up, every setting the host scenario's, is in demo.h. */
#include <stdio.h>
#include <stdlib.h>

#include "demo.h"

int main(void) {
    size_t size = 0;
    td_world *world = demo_world(&size);

    const uint32_t ticks = td_demo_ticks();
    for (uint32_t i = 0; i < ticks; i++) {
        td_vec3 pose, force;
        uint32_t buttons = 0;
        demo_check(td_demo_pose(i, &pose, &buttons), "td_demo_pose");
        demo_check(td_world_tick(world, pose, buttons, &force), "td_world_tick");
    }

    td_counters c;
    demo_check(td_world_counters(world, &c), "td_world_counters");
    td_servo *servo = NULL;
    td_servo_counts sc;
    demo_check(td_world_servo(world, &servo), "td_world_servo");
    demo_check(td_servo_counters(servo, &sc), "td_servo_counters");
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
        demo_check(td_world_region_at(world, i, &r), "td_world_region_at");
        printf("removed_by_region.%d=%.6f\n", (int)r.label, r.removed_volume);
    }
    printf("force_digest=%016llx\n", (unsigned long long)sc.force_digest);

    /* Nothing to tear down in the world: its memory is simply given back. */
    free(world);
    return 0;
}
