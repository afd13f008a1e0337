#!/usr/bin/env bash
# Servo wake-up latency of `tetradrill timing` next to Debian's cyclictest (rt-tests), measured
# back to back in one run with the same settings: 1000 us period, SCHED_FIFO 80, memory
# locked, pinned to the last core. Prints both distributions and the ratio of the p99.9s;
# writes the numbers as JSON to target/latency-vs-cyclictest.json.
#
#   scripts/latency-vs-cyclictest.sh [SECONDS]      (default 30)
#
# Needs root (or CAP_SYS_NICE + a memlock limit) for SCHED_FIFO and mlockall; without it both
# tools run with the default scheduler and the comparison is still like for like.
set -euo pipefail
cd "$(dirname "$0")/.."
secs="${1:-30}"
loops=$(( secs * 1000 ))
core=$(( $(nproc) - 1 ))
out=target/latency-vs-cyclictest
mkdir -p "$out"
command -v cyclictest >/dev/null || { echo "cyclictest not found: apt-get install rt-tests" >&2; exit 2; }
cargo build --release -q -p tetradrill
bin=target/release/tetradrill

echo "cyclictest: $loops loops at 1000 us on core $core" >&2
cyclictest -m -p 80 -a "$core" -t 1 -i 1000 -l "$loops" -q -h 2000 --json="$out/cyclictest.json" \
  > "$out/cyclictest.txt"
echo "tetradrill timing: $secs s at 1000 us (wake-ups only, then with the demo's servo work)" >&2
"$bin" timing --work none --duration "$secs" --json "$out/tetradrill-idle.json" > /dev/null
"$bin" timing --work servo --duration "$secs" --json "$out/tetradrill-work.json" > /dev/null

python3 - "$out" <<'PY'
import json, sys
out = sys.argv[1]

def from_hist(hist):
    """Nearest-rank percentiles from a {latency_us: count} histogram."""
    items = sorted((int(k), int(v)) for k, v in hist.items() if int(v) > 0)
    total = sum(v for _, v in items)
    def rank(per_mille):
        need = -(-per_mille * total // 1000)
        seen = 0
        for k, v in items:
            seen += v
            if seen >= max(need, 1):
                return float(k)
        return float(items[-1][0])
    return {"count": total, "p50": rank(500), "p99": rank(990), "p999": rank(999)}

cy = json.load(open(f"{out}/cyclictest.json"))["thread"]["0"]
c = from_hist(cy["histogram"])
c.update(min=float(cy["min"]), max=float(cy["max"]), mean=float(cy["avg"]))
rows = [("cyclictest", c)]
for name in ("idle", "work"):
    t = json.load(open(f"{out}/tetradrill-{name}.json"))["wake_us"]
    rows.append((f"tetradrill ({name})", t))
print(f"{'wake-up latency us':<22}{'p50':>8}{'p99':>8}{'p99.9':>8}{'max':>9}")
for name, r in rows:
    print(f"{name:<22}{r['p50']:>8.1f}{r['p99']:>8.1f}{r['p999']:>8.1f}{r['max']:>9.1f}")
ratio = {name: (r["p999"] / c["p999"] if c["p999"] > 0 else None) for name, r in rows[1:]}
for name, q in ratio.items():
    print(f"p99.9 ratio {name} / cyclictest: {q:.2f} (target <= 1.20)")
json.dump({"cyclictest": c, "tetradrill_idle": rows[1][1], "tetradrill_work": rows[2][1],
           "p999_ratio": ratio}, open(f"{out}/../latency-vs-cyclictest.json", "w"), indent=2)
PY
