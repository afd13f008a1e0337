/* tetradrill's C interface on a bare Cortex-M4F: the host's `builtin:firmware` scenario (a
 * burr of radius 0.1 drilling the unit block of 4 x 4 x 4 cubes along the demo path, sized for
 * a microcontroller's RAM) tick by tick, the world in a static buffer, the force digest
 * printed through semihosting. scripts/c-example.sh --cortex-m runs it under QEMU and
 * compares the digest with `tetradrill replay --scenario builtin:firmware`'s.
 *
 * Every setting is the host scenario's (host-runner/src/scenario.rs), written as the host
 * derives it: doubles converted to float. */
#include <stddef.h>
#include <stdint.h>

#include "../block.h"
#include "semihost.h"
#include "tetradrill.h"

#define BLOCK_N 4
#define NODES ((BLOCK_N + 1) * (BLOCK_N + 1) * (BLOCK_N + 1))
#define TETS (6 * BLOCK_N * BLOCK_N * BLOCK_N)
/* Room for the world: td_world_size says how much of it the scenario takes. */
#define WORLD_BYTES (2u * 1024u * 1024u)

static float positions[3 * NODES];
static uint32_t tet_nodes[4 * TETS];
static uint8_t world_mem[WORLD_BYTES] __attribute__((aligned(64)));

/* Prints `name=`, `v` in decimal and a newline. */
static void put_u32(const char *name, uint32_t v) {
    char buf[16];
    int i = 15;
    buf[i] = 0;
    do {
        buf[--i] = (char)('0' + v % 10);
        v /= 10;
    } while (v && i > 0);
    sh_puts(name);
    sh_puts("=");
    sh_puts(buf + i);
    sh_puts("\n");
}

/* Prints `name=`, `v` as 16 hex digits and a newline. */
static void put_hex64(const char *name, uint64_t v) {
    char buf[17];
    for (int i = 15; i >= 0; i--) {
        buf[i] = "0123456789abcdef"[v & 0xF];
        v >>= 4;
    }
    buf[16] = 0;
    sh_puts(name);
    sh_puts("=");
    sh_puts(buf);
    sh_puts("\n");
}

/* Prints the status's line and fails when `st` is not TD_OK. */
static int failed(td_status st, const char *what) {
    if (st == TD_OK)
        return 0;
    sh_puts("error: ");
    sh_puts(what);
    sh_puts(": ");
    sh_puts(td_status_name((int32_t)st));
    sh_puts("\n");
    return 1;
}

int main(void) {
    block_write(BLOCK_N, positions, tet_nodes);

    td_params p;
    if (failed(td_params_default(NODES, TETS, &p), "td_params_default"))
        return 1;
    /* The scenario builtin:firmware: the demo's tool and forces ... */
    p.radius = (float)0.1;
    p.reach = 0.5f * p.radius;
    p.stiffness = (float)200.0;
    p.damping = (float)0.5;
    p.max_force = (float)8.0;
    p.dt = (float)1e-3;
    p.switch_time = (float)(16.0 / 1000.0);
    p.servo_lag = 1; /* the RTIC release rule: the servo first, then the step it releases */
    p.min_area = (float)0.0;
    /* ... with its own limits: depth 4, 300 work units a tick, 64 contact nodes, separate
     * bounds, a 20,000-node arena and a 16,384-item deque; candidates and query cells at the
     * core's defaults (what `replay` sizes for this burr on this mesh). */
    p.max_depth = 4;
    p.budget_per_tick = 300;
    p.contact_search_nodes = 64;
    p.tick_budget = 0;
    p.hierarchy_capacity = 20000;
    p.pending_capacity = 16384;
    p.candidate_capacity = 1024;
    p.max_cells = 4096;
    /* No materials in this scenario: the mesh goes in without labels, one region. */
    p.region_capacity = 1;

    size_t size = 0, align = 0;
    if (failed(td_world_size(&p, &size, &align), "td_world_size"))
        return 1;
    put_u32("world_bytes", (uint32_t)size);
    if (size > sizeof world_mem || align > 64) {
        sh_puts("error: the static world buffer is too small for this scenario\n");
        return 1;
    }
    td_world *world = 0;
    uint32_t bad = 0;
    td_status st = td_world_init(world_mem, sizeof world_mem, &p, positions, tet_nodes, NULL, &world, &bad);
    if (st == TD_ERR_MESH)
        put_u32("bad_item", bad);
    if (failed(st, "td_world_init"))
        return 1;

    const uint32_t ticks = td_demo_ticks();
    for (uint32_t i = 0; i < ticks; i++) {
        td_vec3 pose, force;
        uint32_t buttons = 0;
        if (failed(td_demo_pose(i, &pose, &buttons), "td_demo_pose") ||
            failed(td_world_tick(world, pose, buttons, &force), "td_world_tick"))
            return 1;
    }

    td_counters c;
    if (failed(td_world_counters(world, &c), "td_world_counters"))
        return 1;
    put_u32("ticks", (uint32_t)c.servo_ticks);
    put_u32("contact_ticks", (uint32_t)c.contact_ticks);
    put_u32("hierarchy_nodes", (uint32_t)c.hierarchy_nodes);
    put_u32("visible_faces", c.visible_faces);
    put_u32("saturations", c.sat_total);
    put_hex64("force_digest", c.force_digest);
    return 0;
}
