#!/usr/bin/env python3
"""Fit the drill's work weights (core-nostd `drill::WorkCost`) to Cortex-M4 instruction counts.

Input: the firmware's per-tick log, one line per tick
    tick I WHOLE SIMULATE CONTACT TAKEN EXPANDED VISITS CREATED ERASED [QUERY CANDS NODES
    CANDIDATES HITS MISSES]
(instructions of the whole tick, of `World::simulate`, of the contact query redone outside
the tick, then the drill's counts from `DrillReport`; the columns after ERASED, which this fit
does not use, are the candidate query redone, its candidates, the contact search's nodes, the
step's candidates and the sphere memo's hits and misses). The search redone outside the tick
has no sphere memo, so it costs more than the tick's own: that shifts the fitted constant
down, not the weights. Produce it with

    cd ports/mps2-an386
    TETRADRILL_TICK_LOG=1 cargo run --release > /tmp/ticks.txt
    python3 ../../scripts/fit-work-weights.py /tmp/ticks.txt

The fit is ordinary least squares over the ticks where the drill took work, of
`SIMULATE - CONTACT` against a constant and TAKEN, EXPANDED, VISITS, REFINEMENTS (= CREATED / 8).
Erasures are left out: their cost is their NTree visits (a separate column is collinear with
VISITS and comes out negative). The constant is what a drilling tick costs besides its counted
work (the candidate query and the contact search's extra nodes while cutting).

Pure Python (no numpy), so it runs on a fresh machine. Exit status 2 on a bad input line.
"""

import sys

COLUMNS = ["const", "taken", "expanded", "visits", "refinements"]


def solve(a, b):
    """Gaussian elimination with partial pivoting; singular columns get 0."""
    n = len(a)
    m = [row[:] + [b[i]] for i, row in enumerate(a)]
    for c in range(n):
        p = max(range(c, n), key=lambda r: abs(m[r][c]))
        m[c], m[p] = m[p], m[c]
        if abs(m[c][c]) < 1e-12:
            continue
        for r in range(n):
            if r != c:
                f = m[r][c] / m[c][c]
                m[r] = [x - f * y for x, y in zip(m[r], m[c])]
    return [m[i][n] / m[i][i] if abs(m[i][i]) > 1e-12 else 0.0 for i in range(n)]


def main():
    if len(sys.argv) != 2:
        print("usage: fit-work-weights.py TICK_LOG", file=sys.stderr)
        return 2
    path = sys.argv[1]
    xs, ys = [], []
    try:
        lines = open(path, encoding="utf-8", errors="replace").read().splitlines()
    except OSError as e:
        print(f"{path}: cannot read: {e}", file=sys.stderr)
        return 2
    for no, line in enumerate(lines, 1):
        line = line.strip("\r")
        if not line.startswith("tick "):
            continue
        f = line.split()
        if len(f) < 10 or not all(v.isdigit() for v in f[1:]):
            print(f"{path}:{no}: expected `tick` and at least 9 counts, got: {line}", file=sys.stderr)
            return 2
        _, whole, sim, contact, taken, expanded, visits, created, _erased = map(int, f[1:10])
        if taken == 0:
            continue
        xs.append([1.0, taken, expanded, visits, created / 8.0])
        ys.append(float(sim - contact))
    if len(ys) < len(COLUMNS):
        print(f"{path}: only {len(ys)} drilling ticks, too few to fit", file=sys.stderr)
        return 2
    k = len(COLUMNS)
    a = [[sum(x[i] * x[j] for x in xs) for j in range(k)] for i in range(k)]
    b = [sum(x[i] * y for x, y in zip(xs, ys)) for i in range(k)]
    coef = solve(a, b)
    res = sorted(abs(y - sum(c * v for c, v in zip(coef, x))) for x, y in zip(xs, ys))
    print(f"{len(ys)} drilling ticks; instructions a tick besides the contact query: "
          f"mean {sum(ys) / len(ys):.0f}, max {max(ys):.0f}")
    for name, c in zip(COLUMNS, coef):
        print(f"  {name:<12} {c:10.0f} instructions")
    print(f"  |residual| p50 {res[len(res) // 2]:.0f}, p99 {res[len(res) * 99 // 100]:.0f}, "
          f"max {res[-1]:.0f}")
    per = dict(zip(COLUMNS, coef))
    weights = {
        "TAKEN": per["taken"],
        "EXPANDED": per["expanded"],
        "VISIT": per["visits"],
        "CREATED": per["refinements"] / 8.0,
    }
    print("WorkCost (units of 100 instructions, rounded up): "
          + ", ".join(f"{n} {max(1, -(-int(c) // 100))}" for n, c in weights.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
