/* The firmware scenario's block made soft, through the C interface: the body of the host's
 * `builtin:firmware-soft` (Young's modulus 2,000, Poisson ratio 0.3, density 1,000, damping
 * 10 /s, 4 substeps of one sweep, held below the lowest tenth of its height) over the block's
 * arrays, touched through a deformable world, its step and the world's update spread over
 * cycles of 50 servo ticks (20 Hz) by a link (td_link_*), the same work every tick. The C body
 * keeps its tets in its own order (td_soft_init), so its bits are not the Rust firmware's; the
 * host program (soft_firmware.c) and the Cortex-M4 one (cortex_m/main.c built with SOFT_BODY)
 * run this same set-up and print the same digest. */
#ifndef TETRADRILL_EXAMPLE_SOFT_BLOCK_H
#define TETRADRILL_EXAMPLE_SOFT_BLOCK_H

#include "tetradrill.h"

/* Servo ticks a soft step: a step every 50 ms at 1 kHz. */
#define SOFT_BLOCK_TICKS 50u

/* The body's parameters. */
static inline td_status soft_block_params(td_soft_params *sp) {
    td_status st = td_soft_params_default(sp);
    if (st != TD_OK)
        return st;
    sp->young = (float)2000.0;
    sp->poisson = (float)0.3;
    sp->density = 1000.0f;
    sp->damping = 10.0f;
    sp->substeps = 4;
    sp->iterations = 1;
    return TD_OK;
}

/* Sets up the soft body over `xyz` and `tets` (positively oriented) in `soft_mem` and its link
 * to `world` (deformable, over the same arrays) in `link_mem`, each `*_len` bytes at 64-byte
 * alignment or more: the body held below the lowest tenth of its height. `*held` gets the
 * nodes held. TD_ERR_TOO_SMALL when a memory is shorter than its td_*_size. */
static inline td_status soft_block_init(td_world *world, void *soft_mem, size_t soft_len,
                                        void *link_mem, size_t link_len, const float *xyz,
                                        uint32_t nodes, const uint32_t *tets, uint32_t tet_count,
                                        td_soft **body, td_link **link, uint32_t *held) {
    td_soft_params sp;
    size_t size = 0, align = 0;
    uint32_t bad = 0;
    td_status st = soft_block_params(&sp);
    if (st == TD_OK)
        st = td_soft_size(nodes, tet_count, &size, &align);
    if (st == TD_OK && (size > soft_len || align > 64))
        st = TD_ERR_TOO_SMALL;
    if (st == TD_OK)
        st = td_soft_init(soft_mem, soft_len, xyz, nodes, tets, tet_count, &sp, body, &bad);
    if (st != TD_OK)
        return st;
    float lo = xyz[2], hi = xyz[2];
    for (uint32_t i = 1; i < nodes; i++) {
        const float z = xyz[3 * i + 2];
        lo = z < lo ? z : lo;
        hi = z > hi ? z : hi;
    }
    const td_vec3 origin = {0.0f, 0.0f, lo + 0.1f * (hi - lo)}, up = {0.0f, 0.0f, 1.0f};
    st = td_soft_fix_below(*body, origin, up, held);
    if (st == TD_OK)
        st = td_link_size(nodes, &size, &align);
    if (st == TD_OK && (size > link_len || align > 64))
        st = TD_ERR_TOO_SMALL;
    if (st == TD_OK)
        st = td_link_init(link_mem, link_len, world, *body, SOFT_BLOCK_TICKS, 1e-3f, link);
    return st;
}

#endif
