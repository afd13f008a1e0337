/* Replays tetradrill's demo through the C interface and keeps its drilled surface in a
 * renderer's buffers, as a game engine's native plugin would: a surface of triangle slots
 * with smooth per-corner normals (td_surface_init_smooth), updated once a frame (every 17 ticks: 60 Hz at 1 kHz) with a small work
 * budget (td_surface_update), and an engine-side mirror of the buffers that copies only the
 * slot ranges each update reports, as an upload to the GPU would. Once the path ends, the
 * detached crumbs are erased as `replay` erases them (td_world_remove_debris), the updates
 * run until nothing is pending, and the mirror's live triangles are written as a Wavefront
 * OBJ to the file named by the first argument (three vertices, three normals and one face
 * `f a//a b//b c//c` a triangle); scripts/c-example.sh --surface compares its triangles and
 * normals with `tetradrill replay --surface`'s.
 *
 *   surface_demo OUT.obj [BUDGET]
 *
 * Prints `surface_triangles=N` and the per-frame figures (`surface_frames`,
 * `surface_frames_up_to_date`, `surface_max_written`, `surface_max_work`,
 * `surface_max_ranges`, `surface_final_calls`, and the update's wall time a frame,
 * `surface_update_us_mean` and `surface_update_us_max`) and the smooth normals' counters
 * (`smooth_vertices`, `smooth_vertices_full`, `smooth_queue_full`). The world's set-up is demo.h's. */
#define _POSIX_C_SOURCE 200809L /* clock_gettime */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "demo.h"

/* Triangle slots: room for the demo's drilled surface (about 110,000 faces). */
#define MAX_TRIANGLES (1u << 18)
/* Entries of the range list. */
#define RANGES 64
/* Servo ticks a frame. */
#define FRAME_TICKS 17

/* The engine's copy of the buffers: what a GPU would hold. */
typedef struct {
    float *positions, *normals;
    int32_t *labels;
    uint32_t *indices;
} mirror;

/* Seconds on the monotonic clock. */
static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* Copies the slots of each range from the buffers into the mirror. */
static void upload(mirror *m, const td_surface_buffers *b, const td_surface_report *r) {
    for (uint32_t i = 0; i < r->ranges; i++) {
        const size_t v = 3 * (size_t)b->ranges[i].first, n = 3 * (size_t)b->ranges[i].count;
        memcpy(m->positions + 3 * v, b->positions + 3 * v, sizeof(float) * 3 * n);
        memcpy(m->normals + 3 * v, b->normals + 3 * v, sizeof(float) * 3 * n);
        memcpy(m->labels + v, b->labels + v, sizeof(int32_t) * n);
        memcpy(m->indices + v, b->indices + v, sizeof(uint32_t) * n);
    }
}

int main(int argc, char **argv) {
    if (argc < 2) {
        fprintf(stderr, "usage: surface_demo OUT.obj [BUDGET]\n");
        return 2;
    }
    const uint32_t budget = argc > 2 ? (uint32_t)strtoul(argv[2], NULL, 10) : 4096;
    size_t world_size = 0;
    td_world *world = demo_world(&world_size);

    size_t size = 0, align = 0;
    demo_check(td_surface_smooth_size(world, MAX_TRIANGLES, &size, &align),
               "td_surface_smooth_size");
    void *mem = aligned_alloc(align, (size + align - 1) / align * align);
    if (!mem) {
        fprintf(stderr, "surface_demo: out of memory for the surface (%zu bytes)\n", size);
        return 1;
    }
    td_surface *surface = NULL;
    /* Crease angle 0: the core's default (75 degrees). */
    demo_check(td_surface_init_smooth(mem, size, world, MAX_TRIANGLES, 0.0f, &surface),
               "td_surface_init_smooth");

    /* The buffers start zeroed: an empty surface. */
    const size_t verts = 3 * (size_t)MAX_TRIANGLES;
    td_surface_buffers b = {
        .positions = calloc(3 * verts, sizeof(float)),
        .normals = calloc(3 * verts, sizeof(float)),
        .labels = calloc(verts, sizeof(int32_t)),
        .indices = calloc(verts, sizeof(uint32_t)),
        .ranges = calloc(RANGES, sizeof(td_slot_range)),
        .range_capacity = RANGES,
    };
    mirror m = {
        .positions = calloc(3 * verts, sizeof(float)),
        .normals = calloc(3 * verts, sizeof(float)),
        .labels = calloc(verts, sizeof(int32_t)),
        .indices = calloc(verts, sizeof(uint32_t)),
    };
    if (!b.positions || !b.normals || !b.labels || !b.indices || !b.ranges || !m.positions ||
        !m.normals || !m.labels || !m.indices) {
        fprintf(stderr, "surface_demo: out of memory for the buffers\n");
        return 1;
    }

    uint32_t frames = 0, up_to_date = 0, max_written = 0, max_work = 0, max_ranges = 0;
    double update_s = 0.0, update_max_s = 0.0;
    td_surface_report r;
    memset(&r, 0, sizeof r);
    const uint32_t ticks = td_demo_ticks();
    for (uint32_t i = 0; i < ticks; i++) {
        td_vec3 pose, force;
        uint32_t buttons = 0;
        demo_check(td_demo_pose(i, &pose, &buttons), "td_demo_pose");
        demo_check(td_world_tick(world, pose, buttons, &force), "td_world_tick");
        if ((i + 1) % FRAME_TICKS != 0)
            continue;
        /* The frame: one update on the simulation's thread, then the upload. */
        const double t0 = now();
        demo_check(td_surface_update(surface, world, budget, &b, &r), "td_surface_update");
        const double dt = now() - t0;
        update_s += dt;
        if (dt > update_max_s) update_max_s = dt;
        upload(&m, &b, &r);
        frames++;
        up_to_date += r.pending == 0;
        if (r.written > max_written) max_written = r.written;
        if (r.work > max_work) max_work = r.work;
        if (r.ranges > max_ranges) max_ranges = r.ranges;
        if (r.dropped) {
            fprintf(stderr, "surface_demo: %u faces found no slot\n", (unsigned)r.dropped);
            return 1;
        }
    }
    /* As `replay` does once the path ends: the detached crumbs are erased. */
    size_t scratch_len = 0;
    demo_check(td_world_debris_scratch(world, &scratch_len), "td_world_debris_scratch");
    uint32_t *scratch = malloc(sizeof(uint32_t) * (scratch_len ? scratch_len : 1));
    uint32_t pieces = 0;
    if (!scratch) {
        fprintf(stderr, "surface_demo: out of memory for the debris scratch\n");
        return 1;
    }
    demo_check(td_world_remove_debris(world, scratch, scratch_len, &pieces),
               "td_world_remove_debris");
    free(scratch);
    /* The frames after the path: until nothing is pending. */
    uint32_t final_calls = 0;
    do {
        demo_check(td_surface_update(surface, world, budget, &b, &r), "td_surface_update");
        upload(&m, &b, &r);
        final_calls++;
    } while (r.pending != 0 && final_calls < 1000);
    if (r.pending != 0) {
        fprintf(stderr, "surface_demo: still %u units pending after %u calls\n",
                (unsigned)r.pending, (unsigned)final_calls);
        return 1;
    }

    /* The mirror's live triangles (indices not all zero) as OBJ. */
    FILE *out = fopen(argv[1], "w");
    if (!out) {
        perror(argv[1]);
        return 1;
    }
    fprintf(out, "# tetradrill drilled surface through the C interface: the mirror's live slots\n");
    uint32_t n = 0;
    for (uint32_t s = 0; s < r.used; s++) {
        const uint32_t *ix = m.indices + 3 * (size_t)s;
        if (ix[0] == 0 && ix[1] == 0 && ix[2] == 0)
            continue;
        for (int k = 0; k < 3; k++) {
            const float *p = m.positions + 3 * (size_t)ix[k];
            /* %.9g: every float, read back, is the same float. */
            fprintf(out, "v %.9g %.9g %.9g\n", (double)p[0], (double)p[1], (double)p[2]);
        }
        for (int k = 0; k < 3; k++) {
            const float *q = m.normals + 3 * (size_t)ix[k];
            fprintf(out, "vn %.9g %.9g %.9g\n", (double)q[0], (double)q[1], (double)q[2]);
        }
        fprintf(out, "f %u//%u %u//%u %u//%u\n", 3 * n + 1, 3 * n + 1, 3 * n + 2, 3 * n + 2,
                3 * n + 3, 3 * n + 3);
        n++;
    }
    if (fclose(out) != 0) {
        perror(argv[1]);
        return 1;
    }
    printf("surface_triangles=%u\n", (unsigned)n);
    printf("surface_live=%u\n", (unsigned)r.live);
    printf("surface_frames=%u\n", (unsigned)frames);
    printf("surface_frames_up_to_date=%u\n", (unsigned)up_to_date);
    printf("surface_budget=%u\n", (unsigned)budget);
    printf("surface_max_written=%u\n", (unsigned)max_written);
    printf("surface_max_work=%u\n", (unsigned)max_work);
    printf("surface_max_ranges=%u\n", (unsigned)max_ranges);
    printf("surface_final_calls=%u\n", (unsigned)final_calls);
    printf("surface_update_us_mean=%.1f\n", 1e6 * update_s / (frames ? frames : 1));
    printf("surface_update_us_max=%.1f\n", 1e6 * update_max_s);
    printf("surface_bytes=%zu\n", size);
    printf("debris_pieces=%u\n", (unsigned)pieces);
    td_smooth_stats st;
    demo_check(td_surface_smooth_stats(surface, &st), "td_surface_smooth_stats");
    printf("smooth_vertices=%u\n", (unsigned)st.vertices);
    printf("smooth_vertices_full=%u\n", (unsigned)st.vertices_full);
    printf("smooth_queue_full=%u\n", (unsigned)st.queue_full);
    return n == r.live ? 0 : 1;
}
