#!/usr/bin/env bash
# A clinical-size mesh drilled as the coarse one: the teddy (80k tets) and the same shape
# re-meshed at about 2 million tets (scripts/make-fine-mesh.py, tetgen from PyPI), drilled by
# the same burr along the same path (a plunge at the top of the head, a drag, then a hold),
# default capacities, resolution and max depth. Prints removed volume, tick p99 and the buffers chosen for
# each (whole tick, each tick's fastest of 3 runs), and `info`'s load time and resident
# memory per tet for the fine mesh.
#
# Usage: scripts/clinical-drill.sh [HOLD_S]   (default 12: the fine mesh converges)
#        scripts/clinical-drill.sh --moving    (no hold: a plunge, then the burr swept to and
#                                               fro across the head for 4 s, each mesh at the
#                                               drill resolution RESOLUTION, default r/8, and
#                                               at the default max depth, and a drill tool (the
#                                               burr on a shaft 10 r long) at RESOLUTION; the
#                                               removed volume against the Monte Carlo swept
#                                               volume, `--example swept`)
# Env: OUT (work folder, default target/clinical), TETRADRILL_BIN, FINE_TETS (target count
# given to the generator, default 1150000: about 2.06 million tets come out), RESOLUTION.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
moving=0
if [ "${1:-}" = "--moving" ]; then moving=1; shift; fi
hold=${1:-12}
out=${OUT:-$root/target/clinical}
bin=${TETRADRILL_BIN:-$root/target/release/tetradrill}
coarse=$root/tests/data/meshes/models/teddy_cgalbear_tetgen_q1.414
mkdir -p "$out"
[ -x "$bin" ] || (cd "$root" && cargo build --release -p tetradrill)
if [ ! -f "$out/teddy-fine.ele" ]; then
  python3 -c 'import tetgen, numpy' 2>/dev/null || pip install --quiet tetgen numpy
  python3 "$root/scripts/make-fine-mesh.py" "$coarse" "${FINE_TETS:-1150000}" "$out/teddy-fine"
fi
if [ "$moving" = 1 ]; then
  r=0.03
  res=${RESOLUTION:-$(python3 -c "print($r / 8)")}
  python3 - "$coarse.node" > "$out/moving.csv" <<'PY'
import math, sys
rows = [l.split() for l in open(sys.argv[1]) if l.strip() and not l.startswith("#")]
n = int(rows[0][0])
x0, y0, z0 = max((tuple(map(float, r[1:4])) for r in rows[1:n + 1]), key=lambda p: p[2])
r = 0.03
print("t,x,y,z,qw,qx,qy,qz,buttons")
# A plunge from 5r/3 above the top to r below it in 1 s, then to and fro along x over
# +-10r/3 (a sine, two periods in 4 s): the burr never stops.
for i in range(0, 5001, 5):
    t = i / 1000
    if t < 1:
        x, z = x0, z0 + r * (5 / 3 - 8 / 3 * t)
    else:
        x, z = x0 + 10 / 3 * r * math.sin(math.pi * (t - 1)), z0 - r
    print(f"{t},{x:.6f},{y0:.6f},{z:.6f},1,0,0,0,1")
PY
  swept=$root/target/release/examples/swept
  [ -x "$swept" ] || (cd "$root" && cargo build --release -p tetradrill-benches --example swept)
  for m in "$coarse.node" "$out/teddy-fine.ele"; do
    name=$(basename "$m")
    ref=$("$swept" "$m" "$out/moving.csv" "$r" 2000000)
    for mode in "resolution" "depth" "drill"; do
      extra=(--resolution "$res" --max-depth 9)
      [ "$mode" = depth ] && extra=(--resolution 0)
      # The drill tool: the same burr on a shaft ten radii long, 0.4 radii thick.
      tool=sphere:$r
      [ "$mode" = drill ] && tool=drill:$r:$(python3 -c "print(10 * $r)"):$(python3 -c "print(0.4 * $r)")
      "$bin" replay --quiet --repeat 3 --mesh "$m" --trace "$out/moving.csv" --tool "$tool" \
        "${extra[@]}" --json "$out/$name.$mode.json" > "$out/$name.$mode.txt"
      python3 - "$out/$name.$mode.json" "$ref" "$mode" "$res" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
ref = float(sys.argv[2].split()[1])
mode = {"resolution": "resolution " + sys.argv[4], "depth": "max depth only",
        "drill": "drill tool, resolution " + sys.argv[4]}[sys.argv[3]]
print(f"{d['scenario']['mesh'].split('/')[-1]} ({d['mesh']['tets']} tets, {mode}): removed "
      f"{d['removed_volume']:.6g} of swept {ref:.6g} ({100 * (d['removed_volume'] / ref - 1):+.1f} %), "
      f"tick mean {d['timing_us']['tick_mean']:.1f} p99 {d['timing_us']['tick_p99']:.1f} max "
      f"{d['timing_us']['tick_max']:.1f} us, hierarchy nodes {d['hierarchy_nodes']}, "
      f"saturations {d['saturations']['total']} "
      f"{ {k: v for k, v in d['saturations'].items() if v and k != 'total'} }")
PY
    done
  done
  exit 0
fi
python3 - "$coarse.node" "$hold" > "$out/path.csv" <<'PY'
import sys
rows = [l.split() for l in open(sys.argv[1]) if l.strip() and not l.startswith("#")]
n = int(rows[0][0])
x0, y0, z0 = max((tuple(map(float, r[1:4])) for r in rows[1:n + 1]), key=lambda p: p[2])
hold = float(sys.argv[2])
print("t,x,y,z,qw,qx,qy,qz,buttons")
for i in range(0, 3001, 10):
    t = i / 1000
    x, z = (x0, z0 + 0.05 - 0.08 * t) if t < 1 else (x0 + 0.1 * min(t - 1, 2) / 2, z0 - 0.03)
    print(f"{t},{x:.6f},{y0:.6f},{z:.6f},1,0,0,0,1")
print(f"{3 + hold},{x0 + 0.1:.6f},{y0:.6f},{z0 - 0.03:.6f},1,0,0,0,1")
PY
for m in "$coarse.node" "$out/teddy-fine.ele"; do
  name=$(basename "$m")
  "$bin" replay --quiet --repeat 3 --mesh "$m" --trace "$out/path.csv" --tool sphere:0.03 \
    --json "$out/$name.json" > "$out/$name.txt"
  python3 - "$out/$name.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
z = d.get("sizing", {})
print(f"{d['scenario']['mesh'].split('/')[-1]}: {d['mesh']['tets']} tets, removed "
      f"{d['removed_volume']:.6g}, tick p99 {d['timing_us']['tick_p99']:.1f} us, "
      f"saturations {d['saturations']['total']}, candidates {z.get('candidate_capacity')}, "
      f"query cells {z.get('max_cells')}")
PY
done
/usr/bin/time -f "info: %e s, %M KiB peak" "$bin" info --mesh "$out/teddy-fine.ele" \
  --json "$out/info.json" > /dev/null 2> "$out/info.time"
python3 - "$out/info.json" "$out/info.time" <<'PY'
import json, re, sys
tets = json.load(open(sys.argv[1]))["tets"]
s, kib = map(float, re.search(r"info: ([\d.]+) s, (\d+) KiB", open(sys.argv[2]).read()).groups())
print(f"info on {tets} tets: {s:.2f} s ({s / tets * 1e6:.2f} s per million tets), "
      f"{kib * 1024 / tets:.0f} bytes per tet")
PY
