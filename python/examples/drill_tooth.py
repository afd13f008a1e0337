"""Drills the premolar's access cavity (`builtin:firmware-tooth`: a 0.7 mm burr along
`builtin:tooth-access`, through the enamel into the dentin, opening the pulp chamber) and
plots the force on the hand and the volume removed from each tissue against time.

    python python/examples/drill_tooth.py [--png OUT.png] [--json OUT.json]

The JSON holds `removed_by_region` as `tetradrill replay --scenario builtin:firmware-tooth
--json` writes it (the same values: the same ticks, then the same final sweep of the debris).
"""

import argparse
import json
import sys

import numpy as np

import tetradrill as td

NAMES = {1: "enamel", 2: "dentin", 3: "pulp"}


def drill(scenario, chunk):
    """Runs the scenario's trace `chunk` ticks at a time; the per-tick forces and, at the end
    of each chunk, the time and the removed volume by region."""
    d = td.Drilling(scenario=scenario)
    poses, on = d.trace_poses()
    forces = np.empty((len(poses), 3))
    times, removed = [0.0], [d.removed_by_region]
    for i in range(0, len(poses), chunk):
        forces[i : i + chunk] = d.run(poses[i : i + chunk], on[i : i + chunk])
        times.append(d.time)
        removed.append(d.removed_by_region)
    debris = d.erase_debris()
    removed[-1] = d.removed_by_region
    return d, forces, np.array(times), removed, debris


def plot(path, forces, times, removed):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.arange(len(forces)) * td.PERIOD_S
    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(8, 6))
    top.plot(t, np.linalg.norm(forces, axis=1), lw=0.6)
    top.set_ylabel("force on the hand (N)")
    top.set_title("builtin:firmware-tooth: the access cavity")
    for label in sorted(removed[-1]):
        mm3 = [r.get(label, 0.0) * 1e9 for r in removed]
        bottom.plot(times, mm3, label=f"{NAMES.get(label, 'label')} ({label})")
    bottom.set_ylabel("removed (mm$^3$)")
    bottom.set_xlabel("time (s)")
    bottom.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="builtin:firmware-tooth")
    ap.add_argument("--png", default="drill_tooth.png", help="the plot (default %(default)s)")
    ap.add_argument("--json", help="write the removed volume by region as JSON")
    ap.add_argument("--chunk", type=int, default=50, help="ticks between samples of the plot")
    args = ap.parse_args(argv)
    if args.chunk < 1:
        ap.error("--chunk must be at least 1")

    d, forces, times, removed, debris = drill(args.scenario, args.chunk)
    final = removed[-1]
    mags = np.linalg.norm(forces, axis=1)
    print(f"{d.ticks} ticks ({d.time:.3f} s), max force {mags.max():.3f} N, digest {d.force_digest}")
    for label, v in sorted(final.items()):
        print(f"{NAMES.get(label, 'other'):>7} (label {label}): {v * 1e9:.4f} mm^3 removed")
    if debris["pieces"]:
        print(f"debris erased at the end: {debris['pieces']} piece(s), {debris['volume']:.3e}")
    plot(args.png, forces, times, removed)
    print(f"plot: {args.png}")
    if args.json:
        out = {
            "scenario": args.scenario,
            "ticks": d.ticks,
            "initial_volume": d.initial_volume,
            "removed_volume": d.removed_volume,
            "removed_by_region": {str(k): v for k, v in sorted(final.items())},
            "force_digest": d.force_digest,
            "max_force_n": float(mags.max()),
        }
        with open(args.json, "w") as f:
            json.dump(out, f, indent=2)
        print(f"json: {args.json}")
    # Every tissue lost material, and the regions add up to the whole.
    total = sum(final.values())
    if abs(total - d.removed_volume) > 1e-9 * d.removed_volume:
        sys.exit(f"regions sum to {total}, the total is {d.removed_volume}")
    if args.scenario == "builtin:firmware-tooth" and not all(final.get(l, 0) > 0 for l in NAMES):
        sys.exit(f"a tissue lost nothing: {final}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
