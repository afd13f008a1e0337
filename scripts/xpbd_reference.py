#!/usr/bin/env python3
"""An independent XPBD step in numpy, as a check on the core's soft body (docs/SOFT.md).

Written from Macklin, Mueller and Chentanez 2016 (XPBD), docs/SOFT.md's energy (per tet
V (mu |dev E|^2 + K/2 (det F - 1)^2), E the Green strain, K the bulk modulus) as a deviatoric
constraint |dev E| and a volumetric one det F - 1, projected together as one 2x2 system (as
Macklin and Mueller 2021 do for theirs), and docs/SOFT.md's step, in float64 (or float32 with
--float32). Both constraints are evaluated from the displacement gradient H = F - I: the Green
strain as (H + H^T + H^T H) / 2 and det F - 1 from the invariants of H, I1 + I2 + I3. The tets are split into colours (no two
tets of a colour share a node) and each colour is projected at once, vectorised: that is a
Gauss-Seidel sweep in colour order, a different order from the core's (tets in file order), so
the two agree to a tolerance, not bit for bit.

The scenario is the soft bench's (benches/benches/soft.rs): E = 100 kPa, nu = 0.3, density
1000, gravity 9.81 down z, damping 20 /s, the nodes at or below the lowest tenth of the z
extent fixed, steps of 1 ms with 10 substeps of one iteration, from rest.

Usage:
  xpbd_reference.py NODE_FILE STEPS [OURS] [--reverse] [--save OUT] [--iterations N] [--float32]

NODE_FILE is a TetGen .node file with its .ele beside it. Prints the colours, the seconds per
step (the mean over STEPS, the colouring and reading excluded) and the largest displacement.
OURS is the text `soft_positions` writes (benches/src/bin/soft_positions.rs: per node
`x y z ux uy uz fixed`) after the same STEPS: the script matches its nodes to the mesh's by
rest position (the core's loader renumbers them), checks the fixed nodes agree and prints the difference of the largest displacement and the relative L2
difference of the displacement field. --reverse sweeps the colours in reverse order (the
spread between the two orders is the size of an ordering difference alone); --save OUT writes
this side's result in the same format, so a run with --reverse can take it as OURS;
--iterations N (default 1) sets the sweeps per substep; --float32 keeps the state and the
per-tet data in float32, as the core does (the rest data computed in float64, then rounded).
Exit status 1 when the fields differ by more than TOLERANCE (relative L2), 2 with one line
for a bad argument or an unreadable or malformed file.
"""

import sys
import time

import numpy as np

YOUNG = 1e5
POISSON = 0.3
DENSITY = 1000.0
GRAVITY = np.array([0.0, 0.0, -9.81])
DAMPING = 20.0
DT = 1e-3
SUBSTEPS = 10
ITERATIONS = 1
# The relative L2 difference of the displacement fields accepted (docs/SOFT.md, "A peer").
TOLERANCE = 1e-2


class InputError(Exception):
    """One line naming the file, the line and the reason."""


def data_lines(path):
    """The file's (line number, fields) without comments and blank lines."""
    try:
        with open(path, encoding="ascii", errors="replace") as f:
            text = f.read()
    except OSError as e:
        raise InputError(f"{path}: {e.strerror}") from None
    out = []
    for no, line in enumerate(text.splitlines(), 1):
        fields = line.split("#", 1)[0].split()
        if fields:
            out.append((no, fields))
    if not out:
        raise InputError(f"{path}: empty")
    return out


def count(path, no, field, what, most):
    """A whole number in 1..=most, else an InputError."""
    try:
        n = int(field)
    except ValueError:
        raise InputError(f"{path}:{no}: {what} `{field}` is not a whole number") from None
    if not 1 <= n <= most:
        raise InputError(f"{path}:{no}: {what} {n} out of range (1..={most})")
    return n


def read_tetgen(node_path):
    """Rest positions (n, 3) and tets (t, 4), zero-based, of a TetGen .node/.ele pair."""
    if not node_path.endswith(".node"):
        raise InputError(f"{node_path}: not a .node file")
    ele_path = node_path[: -len(".node")] + ".ele"
    lines = data_lines(node_path)
    no, head = lines[0]
    n = count(node_path, no, head[0], "node count", len(lines) - 1)
    if len(head) < 2 or head[1] != "3":
        raise InputError(f"{node_path}:{no}: dimension must be 3")
    x = np.empty((n, 3))
    first = None
    for i, (no, f) in enumerate(lines[1 : n + 1]):
        if len(f) < 4:
            raise InputError(f"{node_path}:{no}: a node needs an index and 3 coordinates")
        try:
            idx = int(f[0])
            x[i] = [float(f[1]), float(f[2]), float(f[3])]
        except ValueError:
            raise InputError(f"{node_path}:{no}: not a number") from None
        if first is None:
            first = idx
        if idx != first + i:
            raise InputError(f"{node_path}:{no}: node index {idx}, expected {first + i}")
        if not np.all(np.isfinite(x[i])):
            raise InputError(f"{node_path}:{no}: non-finite coordinate")
    lines = data_lines(ele_path)
    no, head = lines[0]
    t = count(ele_path, no, head[0], "tet count", len(lines) - 1)
    if len(head) < 2 or head[1] != "4":
        raise InputError(f"{ele_path}:{no}: only 4-node tets are read")
    tets = np.empty((t, 4), dtype=np.int64)
    for i, (no, f) in enumerate(lines[1 : t + 1]):
        if len(f) < 5:
            raise InputError(f"{ele_path}:{no}: a tet needs an index and 4 nodes")
        try:
            tets[i] = [int(v) - first for v in f[1:5]]
        except ValueError:
            raise InputError(f"{ele_path}:{no}: not a whole number") from None
        if tets[i].min() < 0 or tets[i].max() >= n:
            raise InputError(f"{ele_path}:{no}: node index out of range")
    return x, tets


def colour(tets, n):
    """Colours (lists of tet indices) such that no two tets of a colour share a node: greedy,
    the smallest colour none of the tet's nodes has yet."""
    used = [0] * n  # per node, a bit per colour already holding it
    groups = []
    for i, tet in enumerate(tets.tolist()):
        taken = used[tet[0]] | used[tet[1]] | used[tet[2]] | used[tet[3]]
        c = 0
        while taken >> c & 1:
            c += 1
        if c == len(groups):
            groups.append([])
        groups[c].append(i)
        for v in tet:
            used[v] |= 1 << c
    return [np.array(g, dtype=np.int64) for g in groups]


def columns(p):
    """(k, 4, 3) corners to (k, 3, 3) matrices with columns p1 - p0, p2 - p0, p3 - p0."""
    return (p[:, 1:] - p[:, :1]).transpose(0, 2, 1)


class Body:
    """The XPBD body: rest data per tet, masses, state (displacements u, velocities v)."""

    def __init__(self, x, tets, reverse=False, dtype=np.float64):
        dm = columns(x[tets])
        vol = np.linalg.det(dm) / 6.0
        flip = vol < 0.0
        tets = tets.copy()
        tets[flip, 1], tets[flip, 2] = tets[flip, 2], tets[flip, 1].copy()
        dm = columns(x[tets])
        vol = np.linalg.det(dm) / 6.0
        if np.any(vol <= 0.0):
            raise InputError(f"tet {int(np.argmin(vol))} is flat")
        self.x, self.tets, self.vol = x, tets, vol
        self.dm_inv = np.linalg.inv(dm)
        self.dm_inv_t = self.dm_inv.transpose(0, 2, 1)
        mu = YOUNG / (2.0 * (1.0 + POISSON))
        lam = YOUNG * POISSON / ((1.0 + POISSON) * (1.0 - 2.0 * POISSON))
        bulk = lam + 2.0 * mu / 3.0
        # Energy C^2 / (2 alpha): mu |dev E|^2 and K/2 (det F - 1)^2, per rest volume.
        self.alpha_d = 1.0 / (2.0 * mu * vol)
        self.alpha_h = 1.0 / (bulk * vol)
        n = len(x)
        mass = np.zeros(n)
        np.add.at(mass, tets.ravel(), np.repeat(DENSITY * vol / 4.0, 4))
        z = x[:, 2]
        cut = z.min() + 0.1 * (z.max() - z.min())
        self.fixed = (z <= cut) | (mass <= 0.0)
        self.w = np.where(self.fixed, 0.0, 1.0 / np.where(mass > 0.0, mass, 1.0))
        self.colours = colour(tets, n)
        if reverse:
            self.colours.reverse()
        # The state and the per-tet data in `dtype` (float32 computes as the core does).
        self.dtype = dtype
        self.dm_inv = self.dm_inv.astype(dtype)
        self.dm_inv_t = self.dm_inv_t.astype(dtype)
        self.alpha_d = self.alpha_d.astype(dtype)
        self.alpha_h = self.alpha_h.astype(dtype)
        self.w = self.w.astype(dtype)
        self.eye = np.eye(3, dtype=dtype)
        self.gravity = GRAVITY.astype(dtype)
        self.u = np.zeros((n, 3), dtype=dtype)
        self.v = np.zeros((n, 3), dtype=dtype)

    def project(self, c, lam, inv_h2):
        """One coupled projection of every tet of colour c (index array) at once."""
        t = self.tets[c]
        w = self.w[t]  # (k, 4)
        h = columns(self.u[t]) @ self.dm_inv[c]  # displacement gradient, F = I + H
        ht = h.transpose(0, 2, 1)
        strain = 0.5 * (h + ht + ht @ h)  # Green strain (F^T F - I) / 2
        mean = np.trace(strain, axis1=1, axis2=2) / 3.0
        dev = strain - mean[:, None, None] * self.eye
        c_d = np.sqrt(np.einsum("kij,kij->k", dev, dev))
        f = self.eye + h
        # d|dev E|/dF = F dev E / |dev E| (dev E symmetric and traceless).
        p_d = (f @ dev) / np.where(c_d > 0.0, c_d, 1.0)[:, None, None]
        # det(I + H) - 1 = I1 + I2 + I3, the invariants of H.
        i1 = np.trace(h, axis1=1, axis2=2)
        i2 = 0.5 * (i1 * i1 - np.trace(h @ h, axis1=1, axis2=2))
        i3 = np.linalg.det(h)
        c_h = i1 + i2 + i3
        # d det F / dF = cof F: its columns are the cross products of F's other columns.
        f0, f1, f2 = f[:, :, 0], f[:, :, 1], f[:, :, 2]
        p_h = np.stack([np.cross(f1, f2), np.cross(f2, f0), np.cross(f0, f1)], axis=2)

        def grads(p):
            g = (p @ self.dm_inv_t[c]).transpose(0, 2, 1)  # rows: corners 1..3
            return np.concatenate([-g.sum(axis=1, keepdims=True), g], axis=1)

        g_d, g_h = grads(p_d), grads(p_h)
        a00 = np.einsum("kj,kji,kji->k", w, g_d, g_d)
        a01 = np.einsum("kj,kji,kji->k", w, g_d, g_h)
        a11 = np.einsum("kj,kji,kji->k", w, g_h, g_h)
        ad = self.alpha_d[c] * inv_h2
        ah = self.alpha_h[c] * inv_h2
        m00, m11 = a00 + ad, a11 + ah
        r0 = -(c_d + ad * lam[c, 0])
        r1 = -(c_h + ah * lam[c, 1])
        det = m00 * m11 - a01 * a01
        ok = (det > 0.0) & np.isfinite(det)
        det = np.where(ok, det, 1.0)
        dl0 = np.where(ok, (r0 * m11 - a01 * r1) / det, 0.0)
        dl1 = np.where(ok, (m00 * r1 - a01 * r0) / det, 0.0)
        lam[c, 0] += dl0
        lam[c, 1] += dl1
        dx = (g_d * dl0[:, None, None] + g_h * dl1[:, None, None]) * w[:, :, None]
        # No node twice in a colour: a plain indexed add is exact.
        self.u[t] += dx

    def step(self):
        """One step of DT in SUBSTEPS substeps of ITERATIONS colour sweeps each."""
        h = self.dtype(DT / SUBSTEPS)
        inv_h2 = self.dtype(1.0) / (h * h)
        free = ~self.fixed
        lam = np.zeros((len(self.tets), 2), dtype=self.dtype)
        for _ in range(SUBSTEPS):
            self.v[free] = self.v[free] / (1.0 + DAMPING * h) + h * self.gravity
            prev = self.u.copy()
            self.u[free] += h * self.v[free]
            lam[:] = 0.0
            for _ in range(ITERATIONS):
                for c in self.colours:
                    self.project(c, lam, inv_h2)
            self.v = (self.u - prev) / h


def read_ours(path, n):
    """Rest positions, displacements and fixed flags from soft_positions' output."""
    lines = data_lines(path)
    if len(lines) != n:
        raise InputError(f"{path}: {len(lines)} nodes, the mesh has {n}")
    out = np.empty((n, 7))
    for i, (no, f) in enumerate(lines):
        if len(f) != 7:
            raise InputError(f"{path}:{no}: expected `x y z ux uy uz fixed`")
        try:
            out[i] = [float(v) for v in f]
        except ValueError:
            raise InputError(f"{path}:{no}: not a number") from None
    return out[:, :3], out[:, 3:6], out[:, 6] != 0.0


def main(argv):
    args = [a for a in argv if a != "--reverse"]
    reverse = len(args) != len(argv)
    dtype = np.float32 if "--float32" in args else np.float64
    args = [a for a in args if a != "--float32"]
    global ITERATIONS
    if "--iterations" in args:
        i = args.index("--iterations")
        value = args[i + 1] if i + 1 < len(args) else ""
        if not value.isdigit() or not 1 <= int(value) <= 100:
            raise InputError(f"--iterations must be 1..=100, not `{value}`")
        ITERATIONS = int(value)
        del args[i : i + 2]
    save = None
    if "--save" in args:
        i = args.index("--save")
        if i + 1 >= len(args):
            raise InputError("--save needs a file name")
        save = args[i + 1]
        del args[i : i + 2]
    if len(args) not in (2, 3) or any(a.startswith("--") for a in args):
        raise InputError(
            "usage: xpbd_reference.py NODE_FILE STEPS [OURS] [--reverse] [--save OUT] [--iterations N]"
            " [--float32]"
        )
    try:
        steps = int(args[1])
    except ValueError:
        steps = 0
    if steps <= 0:
        raise InputError(f"STEPS must be a positive whole number, not `{args[1]}`")
    x, tets = read_tetgen(args[0])
    try:
        body = Body(x, tets, reverse, dtype)
    except InputError as e:
        raise InputError(f"{args[0][: -len('.node')]}.ele: {e}") from None
    theirs = read_ours(args[2], len(x)) if len(args) == 3 else None
    sizes = [len(c) for c in body.colours]
    print(
        f"{args[0]}: {len(x)} nodes ({int(body.fixed.sum())} fixed), {len(tets)} tets, "
        f"{len(sizes)} colours ({min(sizes)}..{max(sizes)} tets)"
        + (", colours reversed" if reverse else "")
        + (", float32" if dtype is np.float32 else "")
    )
    t0 = time.perf_counter()
    for _ in range(steps):
        body.step()
    per_step = (time.perf_counter() - t0) / steps
    mag = np.linalg.norm(body.u, axis=1)
    print(
        f"{steps} steps of {DT * 1e3:g} ms, {SUBSTEPS} substeps x {ITERATIONS} iterations: "
        f"{per_step:.3f} s a step, max displacement {mag.max():.6e} m"
    )
    if save is not None:
        rows = np.column_stack([x, body.u, body.fixed.astype(np.float64)])
        try:
            np.savetxt(save, rows, fmt=["%.17g"] * 6 + ["%d"])
        except OSError as e:
            raise InputError(f"{save}: {e.strerror}") from None
    if theirs is not None:
        rest, u, fixed = theirs
        # The core's loader renumbers the nodes (a Morton order): match them by rest position.
        ours_order = np.lexsort(rest.astype(np.float32).T[::-1])
        mesh_order = np.lexsort(x.astype(np.float32).T[::-1])
        moved = np.abs(rest[ours_order] - x[mesh_order]).max()
        if moved > 1e-6 * max(1.0, np.abs(x).max()):
            raise InputError(f"{args[2]}: rest positions differ from the mesh by {moved:.3e}")
        perm = np.empty(len(x), dtype=np.int64)
        perm[mesh_order] = ours_order  # mesh node i is our node perm[i]
        rest, u, fixed = rest[perm], u[perm], fixed[perm]
        if np.any(fixed != body.fixed):
            raise InputError(
                f"{args[2]}: {int((fixed != body.fixed).sum())} nodes fixed on one side only"
            )
        ours = np.linalg.norm(u, axis=1)
        rel_l2 = np.linalg.norm(u - body.u) / np.linalg.norm(body.u)
        node_diff = np.linalg.norm(u - body.u, axis=1).max()
        print(
            f"ours: max displacement {ours.max():.6e} m (relative difference "
            f"{abs(ours.max() - mag.max()) / mag.max():.3e}); displacement field: relative "
            f"L2 difference {rel_l2:.3e}, largest node difference {node_diff:.3e} m"
        )
        if not rel_l2 <= TOLERANCE:
            print(f"over the tolerance {TOLERANCE:g} (relative L2)")
            return 1
        print(f"within the tolerance {TOLERANCE:g} (relative L2)")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1:]))
    except InputError as e:
        print(f"xpbd_reference.py: {e}", file=sys.stderr)
        sys.exit(2)
