#!/usr/bin/env python3
"""Re-meshes a tet mesh's boundary at a volume bound: a mesh of the same shape, as fine as
asked (for example a clinical-size teddy of two million tets from the 80k-tet one).

    pip install tetgen numpy
    scripts/make-fine-mesh.py tests/data/meshes/models/teddy_cgalbear_tetgen_q1.414 2000000 OUT

reads IN.node/IN.ele (TetGen, 0- or 1-based), takes the boundary triangles (the faces of
one tet only), tetrahedralizes them with TetGen (quality 1.414) with the volume bound
(total volume / TETS) and writes OUT.node/OUT.ele (0-based). The tet count comes out near
TETS, not exactly. Large outputs are not committed; this script is.
"""
import sys
import time

import numpy as np
import tetgen


def read_tetgen(stem):
    def rows(path):
        out = []
        with open(path) as f:
            for line in f:
                line = line.split("#", 1)[0].split()
                if line:
                    out.append(line)
        return out

    node = rows(stem + ".node")
    n = int(node[0][0])
    ids = np.array([int(r[0]) for r in node[1 : n + 1]])
    pts = np.array([[float(x) for x in r[1:4]] for r in node[1 : n + 1]])
    ele = rows(stem + ".ele")
    t = int(ele[0][0])
    tets = np.array([[int(x) for x in r[1:5]] for r in ele[1 : t + 1]]) - ids.min()
    return pts, tets


def boundary(tets):
    faces = np.concatenate(
        [tets[:, [1, 2, 3]], tets[:, [0, 3, 2]], tets[:, [0, 1, 3]], tets[:, [0, 2, 1]]]
    )
    key = np.sort(faces, axis=1)
    _, inv, count = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    return faces[count[inv.ravel()] == 1]


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    stem, target, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    pts, tets = read_tetgen(stem)
    a, b, c, d = (pts[tets[:, k]] for k in range(4))
    volume = np.abs(np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a))).sum() / 6.0
    tris = boundary(tets)
    used = np.unique(tris)
    remap = np.full(len(pts), -1)
    remap[used] = np.arange(len(used))
    t0 = time.time()
    print(f"{len(tris)} boundary triangles, volume {volume:.6g}, bound {volume / target:.3g}",
          file=sys.stderr)
    gen = tetgen.TetGen(pts[used], remap[tris].astype(np.int32))
    nodes, elems, *_ = gen.tetrahedralize(
        quality=True, minratio=1.414, fixedvolume=True, maxvolume=volume / target, steinerleft=-1
    )
    print(f"{len(nodes)} nodes, {len(elems)} tets in {time.time() - t0:.1f} s", file=sys.stderr)
    with open(out + ".node", "w") as f:
        f.write(f"{len(nodes)} 3 0 0\n")
        for i, p in enumerate(nodes):
            f.write(f"{i} {p[0]:.9g} {p[1]:.9g} {p[2]:.9g}\n")
    with open(out + ".ele", "w") as f:
        f.write(f"{len(elems)} 4 0\n")
        for i, e in enumerate(elems):
            f.write(f"{i} {e[0]} {e[1]} {e[2]} {e[3]}\n")


if __name__ == "__main__":
    main()
