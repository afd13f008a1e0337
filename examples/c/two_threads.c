/* One world, two threads: the servo at 1 kHz on one, the simulation on the other, each calling
 * the C interface while the other runs, as a haptic rig does (a servo thread at the device's
 * rate, the simulation at its own pace). The servo's force call reads the newest contact the
 * simulation published and touches nothing else of the world's; the simulation takes the
 * pressing force from the servo through the same hand-off.
 *
 * The world is the host's `builtin:firmware` scenario (the unit block of 4 x 4 x 4 cubes, a
 * burr of radius 0.1). The servo thread walks the demo path, one tick a millisecond, over and
 * over, for the seconds given (default 10); the simulation thread steps at the servo's
 * newest pose as fast as it can. At the end it prints the counts and checks them: every servo
 * tick and every step succeeded, the servo saw the steps' contacts, the drill removed
 * material. scripts/c-example.sh --tsan builds it with -fsanitize=thread and counts
 * ThreadSanitizer's reports.
 *
 *   two_threads [SECONDS] */
#define _POSIX_C_SOURCE 200809L

#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "block.h"
#include "firmware_params.h"

/* The demo tick whose pose the servo renders now (the device's position, for the simulation). */
static _Atomic uint32_t current_tick;
/* Set by the servo thread when its time is up. */
static _Atomic int done;

struct servo_run {
    td_servo *servo;
    double seconds;
    uint64_t ticks;
    uint64_t late;      /* periods the thread woke more than a period late */
    float force_max;    /* newtons */
    td_status failed;   /* the first status other than TD_OK */
};

static double seconds_between(const struct timespec *a, const struct timespec *b) {
    return (double)(b->tv_sec - a->tv_sec) + 1e-9 * (double)(b->tv_nsec - a->tv_nsec);
}

/* The servo thread: one force a millisecond at the demo path's pose, on an absolute clock. */
static void *servo_thread(void *arg) {
    struct servo_run *r = arg;
    const uint32_t path = td_demo_ticks();
    struct timespec start, next, now;
    clock_gettime(CLOCK_MONOTONIC, &start);
    next = start;
    for (uint64_t n = 0;; n++) {
        clock_gettime(CLOCK_MONOTONIC, &now);
        if (seconds_between(&start, &now) >= r->seconds)
            break;
        if (seconds_between(&next, &now) > 1e-3)
            r->late++;
        td_vec3 pose, force;
        uint32_t buttons = 0;
        const uint32_t i = (uint32_t)(n % path);
        td_status st = td_demo_pose(i, &pose, &buttons);
        atomic_store_explicit(&current_tick, i, memory_order_relaxed);
        if (st == TD_OK)
            st = td_servo_force(r->servo, pose, &force);
        if (st != TD_OK) {
            r->failed = st;
            break;
        }
        const float m2 = force.x * force.x + force.y * force.y + force.z * force.z;
        if (m2 > r->force_max * r->force_max)
            r->force_max = __builtin_sqrtf(m2);
        r->ticks++;
        next.tv_nsec += 1000000;
        if (next.tv_nsec >= 1000000000) {
            next.tv_nsec -= 1000000000;
            next.tv_sec++;
        }
        clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, NULL);
    }
    atomic_store_explicit(&done, 1, memory_order_release);
    return NULL;
}

static void check(td_status st, const char *what) {
    if (st != TD_OK) {
        fprintf(stderr, "two_threads: %s: %s (status %d)\n", what, td_status_name((int32_t)st), (int)st);
        exit(1);
    }
}

int main(int argc, char **argv) {
    double seconds = 10.0;
    if (argc > 2 || (argc == 2 && (sscanf(argv[1], "%lf", &seconds) != 1 || !(seconds > 0.0)))) {
        fprintf(stderr, "two_threads: usage: two_threads [SECONDS] (a positive number, default 10)\n");
        return 2;
    }
    const uint32_t n = FIRMWARE_BLOCK_N, nodes = block_nodes(n), tets = block_tets(n);
    float *positions = malloc(sizeof(float) * 3 * nodes);
    uint32_t *tet_nodes = malloc(sizeof(uint32_t) * 4 * tets);
    if (!positions || !tet_nodes) {
        fprintf(stderr, "two_threads: out of memory for the mesh arrays\n");
        return 1;
    }
    block_write(n, positions, tet_nodes);
    td_params p;
    check(firmware_params(nodes, tets, &p), "td_params_default");
    size_t size = 0, align = 0;
    check(td_world_size(&p, &size, &align), "td_world_size");
    void *mem = aligned_alloc(align, (size + align - 1) / align * align);
    if (!mem) {
        fprintf(stderr, "two_threads: out of memory for the world (%zu bytes)\n", size);
        return 1;
    }
    td_world *world = NULL;
    check(td_world_init(mem, size, &p, positions, tet_nodes, NULL, &world, NULL), "td_world_init");
    struct servo_run run = {.seconds = seconds};
    check(td_world_servo(world, &run.servo), "td_world_servo");

    pthread_t servo;
    if (pthread_create(&servo, NULL, servo_thread, &run) != 0) {
        fprintf(stderr, "two_threads: cannot start the servo thread\n");
        return 1;
    }
    uint64_t steps = 0;
    while (!atomic_load_explicit(&done, memory_order_acquire)) {
        td_vec3 pose;
        uint32_t buttons = 0;
        const uint32_t i = atomic_load_explicit(&current_tick, memory_order_relaxed);
        check(td_demo_pose(i, &pose, &buttons), "td_demo_pose");
        check(td_world_simulate(world, pose, buttons, NULL), "td_world_simulate");
        steps++;
    }
    pthread_join(servo, NULL);
    check(run.failed, "td_servo_force");

    td_counters c;
    td_servo_counts s;
    check(td_world_counters(world, &c), "td_world_counters");
    check(td_servo_counters(run.servo, &s), "td_servo_counters");
    printf("seconds=%.1f\n", seconds);
    printf("servo_ticks=%llu\n", (unsigned long long)s.servo_ticks);
    printf("servo_late=%llu\n", (unsigned long long)run.late);
    printf("simulate_steps=%llu\n", (unsigned long long)c.simulate_steps);
    printf("contact_ticks=%llu\n", (unsigned long long)s.contact_ticks);
    printf("stale_reads=%llu\n", (unsigned long long)s.stale_reads);
    printf("last_step_seen=%u\n", (unsigned)s.step);
    printf("force_max=%.3f\n", (double)run.force_max);
    printf("removed_volume=%.6f\n", c.removed_volume);
    int ok = s.servo_ticks == run.ticks && s.servo_ticks > 0 && steps == c.simulate_steps &&
             s.step > 0 && s.step <= c.simulate_steps && s.contact_ticks > 0 &&
             c.removed_volume > 0.0 && run.force_max <= p.max_force * 1.0001f;
    free(mem);
    free(tet_nodes);
    free(positions);
    if (!ok) {
        fprintf(stderr, "two_threads: FAIL: the counts do not add up (see above)\n");
        return 1;
    }
    printf("two_threads: OK\n");
    return 0;
}
