/* A soft body the burr presses, through the C interface: a mesh file read once, a deformable
 * world over it (td_params.deformable) and a soft body over the same arrays, held below the
 * lowest tenth of its height. A burr of radius 0.05 is lowered onto the top node, 0.02 deep,
 * and held, the drill off, for a second: each servo tick's reaction loads the body where the
 * burr touches it (td_world_contact_at, td_soft_add_point_force); every 4 ticks (250 Hz) the
 * body steps under their mean and the world takes its positions (td_world_set_positions). A
 * rigid world pressed the same way is the comparison. Prints the dent, both forces and the
 * step's and the update's mean wall time; exits 1 unless the body gave way (the contact point
 * sank and the force's mean over the last 200 ticks is below the rigid world's).
 *
 * With --spread T the body's step and the world's update are spread over the servo ticks
 * instead (td_link_*): a step every T ticks, each tick doing the same share of it, the world
 * taking the new positions at each cycle's last tick; it prints each tick's share (work units)
 * and the link's mean and longest wall time a tick.
 *
 *   soft_demo MESH [--spread T]   (a file tetradrill reads: the cow,
 *                                  tests/data/meshes/models/spot_tetgen_q1.414.node)
 */
#define _POSIX_C_SOURCE 200809L /* clock_gettime */

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "tetradrill.h"

#define TICKS 1000
#define TICKS_PER_STEP 4
#define RADIUS 0.05f
#define PRESS 0.02f
#define LAST 200 /* the ticks the force's mean is taken over */

static void check(td_status st, const char *what) {
    if (st != TD_OK) {
        fprintf(stderr, "soft_demo: %s: %s (status %d)\n", what, td_status_name((int32_t)st), (int)st);
        exit(1);
    }
}

static double now_ms(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return 1e3 * (double)t.tv_sec + 1e-6 * (double)t.tv_nsec;
}

static void *alloc(size_t size, size_t align) {
    void *p = aligned_alloc(align, (size + align - 1) / align * align);
    if (!p) {
        fprintf(stderr, "soft_demo: out of memory\n");
        exit(1);
    }
    return p;
}

/* A world over the arrays (deformable or rigid) with a 0.05 burr. */
static td_world *world_of(const td_mesh_arrays *a, int deformable) {
    td_params p;
    check(td_params_default(a->node_count, a->tet_count, &p), "td_params_default");
    p.radius = RADIUS;
    p.reach = 0.5f * RADIUS;
    p.deformable = (uint32_t)deformable;
    size_t size, align;
    check(td_world_size(&p, &size, &align), "td_world_size");
    td_world *w;
    uint32_t bad = 0;
    check(td_world_init(alloc(size, align), size, &p, a->positions, a->tets, NULL, &w, &bad),
          "td_world_init");
    /* A material that never gives way to the burr: the drill is off anyway. */
    check(td_world_set_region(w, 0, 0.f, 1e9f, 0.f), "td_world_set_region");
    return w;
}

int main(int argc, char **argv) {
    long spread = 0;
    if (argc == 4 && strcmp(argv[2], "--spread") == 0) {
        char *end;
        spread = strtol(argv[3], &end, 10);
        if (*end != '\0' || spread < 1 || spread > 1000) {
            fprintf(stderr, "soft_demo: --spread %s: ticks a step, 1 to 1000\n", argv[3]);
            return 2;
        }
    } else if (argc != 2) {
        fprintf(stderr, "soft_demo: usage: soft_demo MESH [--spread TICKS]\n");
        return 2;
    }
    td_mesh_file *file;
    td_file_error err;
    if (td_mesh_file_read(argv[1], 1.0, &file, &err) != TD_OK) {
        fprintf(stderr, "soft_demo: %s\n", err.message);
        return 2;
    }
    td_mesh_arrays a;
    check(td_mesh_file_arrays(file, &a), "td_mesh_file_arrays");
    const uint32_t n = a.node_count;

    /* The soft body takes its tets positively oriented (the world flips its own). */
    uint32_t *tets = malloc(sizeof(uint32_t) * 4 * a.tet_count);
    float *xyz = malloc(sizeof(float) * 3 * n);
    float *loads = calloc(3 * (size_t)n, sizeof(float));
    if (!tets || !xyz || !loads) {
        fprintf(stderr, "soft_demo: out of memory\n");
        return 1;
    }
    for (uint32_t t = 0; t < a.tet_count; t++) {
        const uint32_t *q = a.tets + 4 * t;
        const float *p0 = a.positions + 3 * q[0];
        float e[3][3];
        for (int k = 0; k < 3; k++)
            for (int c = 0; c < 3; c++)
                e[k][c] = a.positions[3 * q[k + 1] + c] - p0[c];
        float det = e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) -
                    e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
                    e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
        memcpy(tets + 4 * t, q, 4 * sizeof(uint32_t));
        if (det < 0) {
            tets[4 * t + 1] = q[2];
            tets[4 * t + 2] = q[1];
        }
    }
    /* The top node, and the height the body is held below. */
    uint32_t top = 0;
    float lo = INFINITY, hi = -INFINITY;
    for (uint32_t i = 0; i < n; i++) {
        float z = a.positions[3 * i + 2];
        if (z > hi) {
            hi = z;
            top = i;
        }
        lo = z < lo ? z : lo;
    }

    td_world *soft_world = world_of(&a, 1), *rigid = world_of(&a, 0);
    td_soft_params sp;
    check(td_soft_params_default(&sp), "td_soft_params_default");
    sp.damping = 10.f;
    size_t size, align;
    check(td_soft_size(n, a.tet_count, &size, &align), "td_soft_size");
    td_soft *body;
    uint32_t bad = 0;
    check(td_soft_init(alloc(size, align), size, a.positions, n, tets, a.tet_count, &sp, &body,
                       &bad),
          "td_soft_init");
    uint32_t held = 0;
    check(td_soft_fix_below(body, (td_vec3){0.f, 0.f, lo + 0.1f * (hi - lo)},
                            (td_vec3){0.f, 0.f, 1.f}, &held),
          "td_soft_fix_below");

    /* The spread step: a link between the body and the world. */
    td_link *link = NULL;
    td_link_counts lc = {0};
    if (spread) {
        check(td_link_size(n, &size, &align), "td_link_size");
        check(td_link_init(alloc(size, align), size, soft_world, body, (uint32_t)spread, 1e-3f,
                           &link),
              "td_link_init");
        check(td_link_counters(link, &lc), "td_link_counters");
    }

    const float *t0 = a.positions + 3 * top;
    td_vec3 f = {0}, fr = {0};
    td_contact_at at = {0};
    double step_ms = 0, update_ms = 0, fastest = INFINITY, tick_ms = 0, longest = 0;
    int steps = 0, skipped = 0;
    uint32_t most = 0;
    td_contact_at touched = {TD_NO_TET, {0.f, 0.f, 0.f}};
    float fmean = 0.f;
    const int ticks = spread ? 2 * TICKS : TICKS;
    for (int i = 0; i < ticks; i++) {
        const float s = i < 200 ? (float)i / 200.f : 1.f;
        const td_vec3 pose = {t0[0], t0[1], t0[2] + RADIUS - s * PRESS};
        check(td_world_tick(soft_world, pose, 0, &f), "td_world_tick");
        check(td_world_tick(rigid, pose, 0, &fr), "td_world_tick (rigid)");
        check(td_world_contact_at(soft_world, &at), "td_world_contact_at");
        if (at.tet != TD_NO_TET)
            touched = at;
        if (i >= ticks - LAST)
            fmean += f.z / LAST;
        if (link) {
            td_link_report r;
            double t = now_ms();
            check(td_link_tick(link, soft_world, body, f, &r), "td_link_tick");
            t = now_ms() - t;
            tick_ms += t;
            longest = t > longest ? t : longest;
            most = r.units > most ? r.units : most;
            steps += (int)r.committed;
            continue;
        }
        /* The reaction where the burr touches; a tet flattened under the load
         * (TD_ERR_INPUT) takes none, as the host skips it. */
        if (at.tet != TD_NO_TET && (f.x != 0.f || f.y != 0.f || f.z != 0.f) &&
            td_soft_add_point_force(body, at.tet, at.point, (td_vec3){-f.x, -f.y, -f.z},
                                    loads) != TD_OK)
            skipped++;
        if ((i + 1) % TICKS_PER_STEP != 0)
            continue;
        for (size_t k = 0; k < 3 * (size_t)n; k++)
            loads[k] /= TICKS_PER_STEP;
        double t = now_ms();
        check(td_soft_step(body, TICKS_PER_STEP * 1e-3f, loads), "td_soft_step");
        check(td_soft_nodes(body, TD_SOFT_POSITIONS, xyz, n), "td_soft_nodes");
        double u = now_ms();
        check(td_world_set_positions(soft_world, xyz, n, NULL), "td_world_set_positions");
        update_ms += now_ms() - u;
        step_ms += u - t;
        fastest = u - t < fastest ? u - t : fastest;
        steps++;
        memset(loads, 0, 3 * (size_t)n * sizeof(float));
    }
    const float dent = t0[2] - touched.point.z;
    printf("soft: %u tets, %u held; dent %.5f, force %.4f N (%.4f N over the last %d ticks) "
           "against the rigid world's %.4f N; %d reactions skipped\n",
           a.tet_count, held, dent, f.z, fmean, LAST, fr.z, skipped);
    if (link) {
        check(td_link_counters(link, &lc), "td_link_counters");
        printf("soft: spread over %ld ticks: %d steps, %u units a tick (at most %u done), "
               "link %.3f ms a tick (mean), %.3f ms longest, %u late\n",
               spread, steps, lc.units_per_tick, most, tick_ms / ticks, longest, lc.late);
    } else {
        printf("soft: %d steps, step %.2f ms (fastest %.2f ms), world update %.2f ms (means)\n",
               steps, step_ms / steps, fastest, update_ms / steps);
    }
    td_mesh_file_free(file);
    if (!(touched.tet != TD_NO_TET && dent > 1e-3f && fmean > 0.f && fmean < fr.z)) {
        fprintf(stderr, "soft_demo: the body did not give way under the burr\n");
        return 1;
    }
    return 0;
}
