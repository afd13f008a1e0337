/* tetradrill's C interface on a bare Cortex-M4F, in two tasks as a haptic controller runs it:
 * the servo's force in the SysTick interrupt, once a period, and the simulation step in the
 * main loop below it, which the interrupt preempts. The scenario is the host's
 * `builtin:firmware` (a burr of radius 0.1 drilling the unit block of 4 x 4 x 4 cubes along the
 * demo path, sized for a microcontroller's RAM), the world in a static buffer.
 *
 * Each period: the interrupt renders the force at the tick's pose from the newest contact the
 * steps published (the previous tick's step: the RTIC release rule, `servo_lag` 1) and
 * releases the tick's step; the main loop runs it and waits for the next. A step still running
 * at the next event is a deadline miss (counted and printed): the servo then renders from an
 * older contact. The period is 168,000 instructions (1 ms at 168 MHz, one instruction a
 * cycle) under QEMU's `-icount shift=10`. The force the interrupt would write to the motors
 * goes through a passivity observer first (td_passivity_step, fed what the burr's spring holds
 * at the pose, td_servo_storage), as a device's servo runs it: its trips and the energy its
 * damper took are printed. The force digest is printed through semihosting;
 * scripts/c-example.sh --cortex-m compares it with `tetradrill replay --scenario
 * builtin:firmware`'s.
 *
 * Built with MESH_BLOB defined (make BLOB=FILE), the block comes from a mesh blob in flash
 * (`tetradrill export --firmware FILE --mesh builtin:block:4`), its tets read in place by
 * td_world_init_blob, instead of being built from arrays.
 *
 * Built with SOFT_BODY defined (the soft_firmware.elf target), the world is deformable and the
 * block soft (../soft_block.h): after each step the main loop hands the tick's force to the
 * link (td_link_tick), which does the same share of the body's step and of the world's update
 * every tick and moves the world every 50 ticks; its digest is compared with the host's run of
 * the same set-up (../soft_firmware.c). */
#include <stddef.h>
#include <stdint.h>

#include "../block.h"
#include "../firmware_params.h"
#include "semihost.h"
#ifdef SOFT_BODY
#include "../soft_block.h"
#endif

#define BLOCK_N FIRMWARE_BLOCK_N
#define NODES ((BLOCK_N + 1) * (BLOCK_N + 1) * (BLOCK_N + 1))
#define TETS (6 * BLOCK_N * BLOCK_N * BLOCK_N)
/* Room for the world: td_world_size says how much of it the scenario takes. */
#define WORLD_BYTES (2u * 1024u * 1024u)

#ifndef MESH_BLOB
static float positions[3 * NODES];
static uint32_t tet_nodes[4 * TETS];
#endif
static uint8_t world_mem[WORLD_BYTES] __attribute__((aligned(64)));
/* The device's metres a mesh unit: the block's half diagonal (sqrt(3) / 2) onto a workspace
 * of radius 0.04 m (a Novint Falcon's, whose 8 N the scenario's force limit is), as the host
 * maps a device's workspace onto a mesh. */
#define TO_SI (0.04f / 0.8660254f)
/* Room for the servo's passivity observer (td_passivity_size says how much). */
static uint8_t passivity_mem[256] __attribute__((aligned(64)));
static td_passivity *passivity;
/* The tick of the observer's first trip (UINT32_MAX: none), ticks out of contact since. */
static volatile uint32_t first_trip = UINT32_MAX;
static uint32_t free_ticks;
#ifdef SOFT_BODY
/* Room for the soft body and its link (td_soft_size and td_link_size say how much). */
static uint8_t soft_mem[48u * 1024u] __attribute__((aligned(64)));
static uint8_t link_mem[8u * 1024u] __attribute__((aligned(64)));
/* The servo's force of the last ticks, by tick (the step of tick i hands forces[i % 4] to the
 * link; the interrupt is at most a tick or two ahead). */
static volatile float forces[4][3];
#endif

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

/* SysTick (ARMv7-M): control and status, reload, current value. */
#define SYST_CSR (*(volatile uint32_t *)0xE000E010u)
#define SYST_RVR (*(volatile uint32_t *)0xE000E014u)
#define SYST_CVR (*(volatile uint32_t *)0xE000E018u)
/* The servo period in instructions, and in SysTick counts: QEMU's `-icount shift=10` makes an
 * instruction 1,024 ns of virtual time, and the MPS2 SysTick counts the 25 MHz processor
 * clock (40 ns a count). */
#define PERIOD_INSTRUCTIONS 168000u
#define PERIOD_COUNTS (PERIOD_INSTRUCTIONS * 1024u / 40u)

static td_servo *servo;
static uint32_t ticks;
/* Ticks the servo has run (written by the interrupt only). */
static volatile uint32_t released;
/* Steps the main loop has finished (written by the main loop only). */
static volatile uint32_t stepped;
/* Events that found the previous tick's step unfinished. */
static volatile uint32_t misses;
/* The first failed status in the interrupt (TD_OK: none). */
static volatile td_status servo_status = TD_OK;

/* The servo's timer event: the force at this tick's pose from the newest published contact,
 * then this tick's step released to the main loop. */
void systick_handler(void) {
    const uint32_t i = released;
    if (i >= ticks)
        return;
    if (stepped != i)
        misses = misses + 1;
    td_vec3 pose = {0.f, 0.f, 0.f}, force = {0.f, 0.f, 0.f};
    uint32_t buttons = 0;
    td_status st = td_demo_pose(i, &pose, &buttons);
    if (st == TD_OK)
        st = td_servo_force(servo, pose, &force);
    /* The force through the passivity observer, which works in SI: the device's positions
     * (the mesh's over the workspace's scale) and what the burr's spring holds at the pose
     * (newton mesh units, over the scale: joules); the drill on (bit 0) removes material by
     * design. */
    td_storage stored = {0.f, 0.f};
    td_vec3 sent = {0.f, 0.f, 0.f};
    if (st == TD_OK)
        st = td_servo_storage(servo, pose, NULL, &stored);
    stored.stored_j *= TO_SI;
    stored.past_limit_j *= TO_SI;
    const td_vec3 at = {pose.x * TO_SI, pose.y * TO_SI, pose.z * TO_SI};
    if (st == TD_OK)
        st = td_passivity_step(passivity, at, force, &stored, buttons & 1u, &sent);
    if (st != TD_OK && servo_status == TD_OK)
        servo_status = st;
    /* A trip latches zero force; as the host's servo does, it is cleared once the tool has
     * been out of contact for a second (the device then ramps the force back in). */
    td_passivity_counts pc;
    if (st == TD_OK && td_passivity_counters(passivity, &pc) == TD_OK && pc.tripped) {
        if (first_trip == UINT32_MAX)
            first_trip = i;
        free_ticks = force.x == 0.f && force.y == 0.f && force.z == 0.f ? free_ticks + 1 : 0;
        if (free_ticks >= 1000u) {
            free_ticks = 0;
            st = td_passivity_reset(passivity, 0, 1, 0);
            if (st != TD_OK && servo_status == TD_OK)
                servo_status = st;
        }
    }
    /* On a device: write `sent` to the motors here. */
#ifdef SOFT_BODY
    forces[i % 4][0] = force.x;
    forces[i % 4][1] = force.y;
    forces[i % 4][2] = force.z;
#endif
    released = i + 1;
}

#ifdef MESH_BLOB
/* The blob's bytes (blob.S). */
extern const uint8_t mesh_blob[], mesh_blob_end[];
#endif

int main(void) {
    td_params p;
    size_t size = 0, align = 0;
#ifdef MESH_BLOB
    const size_t blob_len = (size_t)(mesh_blob_end - mesh_blob);
    uint32_t nodes = 0, tets = 0, bad_byte = 0;
    td_status counted = td_blob_counts(mesh_blob, blob_len, &nodes, &tets, &bad_byte);
    if (counted == TD_ERR_BLOB)
        put_u32("bad_byte", bad_byte);
    if (failed(counted, "td_blob_counts") || failed(firmware_params(nodes, tets, &p), "td_params_default"))
        return 1;
    /* The blob carries the block's labels (its shell and its core): two regions, both of the
     * default material, which drills as no material does. */
    p.region_capacity = 2;
    if (failed(td_world_size_blob(&p, &size, &align), "td_world_size_blob"))
        return 1;
    sh_puts("mesh=blob\n");
#else
    block_write(BLOCK_N, positions, tet_nodes);
    if (failed(firmware_params(NODES, TETS, &p), "td_params_default"))
        return 1;
#ifdef SOFT_BODY
    p.deformable = 1;
#endif
    if (failed(td_world_size(&p, &size, &align), "td_world_size"))
        return 1;
    sh_puts("mesh=arrays\n");
#endif
    put_u32("world_bytes", (uint32_t)size);
    if (size > sizeof world_mem || align > 64) {
        sh_puts("error: the static world buffer is too small for this scenario\n");
        return 1;
    }
    td_world *world = 0;
    uint32_t bad = 0;
#ifdef MESH_BLOB
    td_status st = td_world_init_blob(world_mem, sizeof world_mem, &p, mesh_blob, blob_len, &world, &bad);
#else
    td_status st = td_world_init(world_mem, sizeof world_mem, &p, positions, tet_nodes, NULL, &world, &bad);
#endif
    if (st == TD_ERR_MESH || st == TD_ERR_BLOB)
        put_u32("bad_item", bad);
    if (failed(st, "td_world_init") || failed(td_world_servo(world, &servo), "td_world_servo"))
        return 1;
    /* The observer at the servo's period, the force limit the world's. */
    td_passivity_params pp;
    if (failed(td_passivity_params_default(&pp), "td_passivity_params_default"))
        return 1;
    pp.dt = p.dt;
    pp.max_force = p.max_force;
    if (failed(td_passivity_init(passivity_mem, sizeof passivity_mem, &pp, &passivity),
               "td_passivity_init"))
        return 1;
#ifdef SOFT_BODY
    td_soft *body = 0;
    td_link *link = 0;
    uint32_t held = 0;
    if (failed(soft_block_init(world, soft_mem, sizeof soft_mem, link_mem, sizeof link_mem,
                               positions, NODES, tet_nodes, TETS, &body, &link, &held),
               "soft_block_init"))
        return 1;
    put_u32("held", held);
    uint32_t most = 0;
#endif

    ticks = td_demo_ticks();
    sh_puts("servo=systick\n");
    SYST_RVR = PERIOD_COUNTS - 1;
    SYST_CVR = 0;
    SYST_CSR = 0x7u; /* the processor clock, the interrupt, the counter on */
    while (stepped < ticks) {
        /* Wait for the servo to release the next step. */
        while (released == stepped)
            __asm__ volatile("wfi" ::: "memory");
        const uint32_t i = stepped;
        td_vec3 pose;
        uint32_t buttons = 0;
        if (failed(td_demo_pose(i, &pose, &buttons), "td_demo_pose") ||
            failed(td_world_simulate(world, pose, buttons, NULL), "td_world_simulate"))
            return 1;
#ifdef SOFT_BODY
        /* The interrupt is at most a tick or two ahead; four ticks would have overwritten
         * this tick's force. */
        if (released - i >= 4u) {
            sh_puts("error: the servo ran four ticks ahead of the link\n");
            return 1;
        }
        const td_vec3 f = {forces[i % 4][0], forces[i % 4][1], forces[i % 4][2]};
        td_link_report r;
        if (failed(td_link_tick(link, world, body, f, &r), "td_link_tick"))
            return 1;
        most = r.units > most ? r.units : most;
#endif
        stepped = i + 1;
    }
    SYST_CSR = 0;
    if (failed(servo_status, "td_servo_force"))
        return 1;

    td_counters c;
    td_servo_counts s;
    if (failed(td_world_counters(world, &c), "td_world_counters") ||
        failed(td_servo_counters(servo, &s), "td_servo_counters"))
        return 1;
    put_u32("ticks", (uint32_t)s.servo_ticks);
    put_u32("steps", (uint32_t)c.simulate_steps);
    put_u32("deadline_misses", misses);
    put_u32("contact_ticks", (uint32_t)s.contact_ticks);
    put_u32("hierarchy_nodes", (uint32_t)c.hierarchy_nodes);
    put_u32("visible_faces", c.visible_faces);
    put_u32("saturations", c.sat_total);
    td_passivity_counts pc;
    if (failed(td_passivity_counters(passivity, &pc), "td_passivity_counters"))
        return 1;
    put_u32("passivity_trips", pc.trips);
    if (first_trip != UINT32_MAX)
        put_u32("passivity_first_trip", first_trip);
    put_u32("passivity_dissipated_uj", (uint32_t)(pc.dissipated_j * 1e6));
#ifdef SOFT_BODY
    td_link_counts lc;
    if (failed(td_link_counters(link, &lc), "td_link_counters"))
        return 1;
    put_u32("soft_steps", lc.steps);
    put_u32("units_per_tick", lc.units_per_tick);
    put_u32("units_most", most);
    put_u32("late", lc.late);
    put_u32("max_displacement_um", (uint32_t)(lc.max_displacement * 1e6f));
#endif
    put_hex64("force_digest", s.force_digest);
    return misses == 0 ? 0 : 1;
}
