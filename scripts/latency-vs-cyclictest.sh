#!/usr/bin/env bash
# Servo wake-up latency of `tetradrill timing` next to Debian's cyclictest (rt-tests), measured
# interleaved with the same settings: 1000 us period, SCHED_FIFO 80, memory locked, pinned to the
# last core. The run is PAIRS rounds; each round runs one segment of SECONDS of each tool
# (cyclictest, `tetradrill timing --work servo`, `tetradrill timing --work none`), in the reverse
# order every other round so that a slow drift of the machine's load falls on both sides alike.
# Each round gives one p99.9 ratio per tetradrill workload (tetradrill's p99.9 over cyclictest's
# in the same round); the script prints the median, minimum, maximum and interquartile range of
# those ratios, and each tool's percentiles (the median over the rounds), and writes them as JSON to
# target/latency-vs-cyclictest.json (per-segment files in target/latency-vs-cyclictest/).
#
#   scripts/latency-vs-cyclictest.sh [SECONDS] [PAIRS]
#
# SECONDS is the length of one segment (default 10), PAIRS the number of rounds (default 10):
# the default run measures each tool for 100 s in ten 10 s segments and takes about 5 minutes.
# WORKS="servo" (default "servo none") chooses the tetradrill workloads.
#
# Needs root (or CAP_SYS_NICE + a memlock limit) for SCHED_FIFO and mlockall; without it both
# tools run with the default scheduler and the comparison is still like for like.
set -euo pipefail
cd "$(dirname "$0")/.."
secs="${1:-10}"
pairs="${2:-10}"
works="${WORKS:-servo none}"
[[ "$secs" =~ ^[1-9][0-9]*$ ]] || { echo "latency-vs-cyclictest.sh: SECONDS must be a positive whole number, got '$secs'" >&2; exit 2; }
[[ "$pairs" =~ ^[1-9][0-9]*$ ]] || { echo "latency-vs-cyclictest.sh: PAIRS must be a positive whole number, got '$pairs'" >&2; exit 2; }
for w in $works; do
  [[ "$w" == servo || "$w" == none ]] || { echo "latency-vs-cyclictest.sh: WORKS takes 'servo' and 'none', got '$w'" >&2; exit 2; }
done
loops=$(( secs * 1000 ))
core=$(( $(nproc) - 1 ))
out=target/latency-vs-cyclictest
rm -rf "$out"
mkdir -p "$out"
command -v cyclictest >/dev/null || { echo "cyclictest not found: apt-get install rt-tests" >&2; exit 2; }
cargo build --release -q -p tetradrill
bin="${CARGO_TARGET_DIR:-target}/release/tetradrill"

run_cyclictest() {
  cyclictest -m -p 80 -a "$core" -t 1 -i 1000 -l "$loops" -q -h 2000 --json="$out/cyclictest-$1.json" \
    > "$out/cyclictest-$1.txt"
}
run_tetradrill() {
  "$bin" timing --work "$2" --duration "$secs" --json "$out/tetradrill-$2-$1.json" > /dev/null 2>"$out/tetradrill-$2-$1.err"
}

echo "$pairs rounds of $secs s segments at 1000 us on core $core: cyclictest and tetradrill ($works)" >&2
for (( r = 0; r < pairs; r++ )); do
  if (( r % 2 == 0 )); then
    run_cyclictest "$r"
    for w in $works; do run_tetradrill "$r" "$w"; done
  else
    for w in $works; do run_tetradrill "$r" "$w"; done
    run_cyclictest "$r"
  fi
  echo "round $(( r + 1 )) of $pairs done" >&2
done

python3 - "$out" "$pairs" "$works" "$secs" <<'PY'
import json, sys
out, pairs, works, secs = sys.argv[1], int(sys.argv[2]), sys.argv[3].split(), int(sys.argv[4])

def percentiles(counts, overflow_value):
    """Nearest-rank p50, p99 and p99.9 from {latency_us: count}; overflow_value for samples past it."""
    items = sorted((k, v) for k, v in counts.items() if v > 0)
    total = sum(v for _, v in items)
    def rank(per_mille):
        need = max(-(-per_mille * total // 1000), 1)
        seen = 0
        for k, v in items:
            seen += v
            if seen >= need:
                return float(k)
        return float(overflow_value)
    return {"count": total, "p50": rank(500), "p99": rank(990), "p999": rank(999)}

def cyclictest(r):
    t = json.load(open(f"{out}/cyclictest-{r}.json"))["thread"]["0"]
    hist = {int(k): int(v) for k, v in t["histogram"].items()}
    over = int(t["cycles"]) - sum(hist.values())
    if over > 0:  # past the 2000 us histogram: counted at the segment's maximum
        hist[int(t["max"])] = hist.get(int(t["max"]), 0) + over
    return hist, float(t["max"])

def quartiles(xs):
    """Median, min, max and interquartile range (linear interpolation between ranks)."""
    s = sorted(xs)
    def q(p):
        x = p * (len(s) - 1)
        lo = int(x)
        hi = min(lo + 1, len(s) - 1)
        return s[lo] + (s[hi] - s[lo]) * (x - lo)
    return {"median": q(0.5), "min": s[0], "max": s[-1], "q1": q(0.25), "q3": q(0.75),
            "iqr": q(0.75) - q(0.25)}

rounds = []
for r in range(pairs):
    ch, cmax = cyclictest(r)
    c = percentiles(ch, cmax)
    c["max"] = cmax
    row = {"round": r + 1, "cyclictest": c}
    for w in works:
        summary = json.load(open(f"{out}/tetradrill-{w}-{r}.json"))["wake_us"]
        row[f"tetradrill_{w}"] = {"p50": summary["p50"], "p99": summary["p99"],
                                  "p999": summary["p999"], "max": summary["max"]}
        row[f"ratio_{w}"] = summary["p999"] / c["p999"] if c["p999"] > 0 else None
    rounds.append(row)

print(f"{'round':<7}{'cyclictest p99.9':>18}" + "".join(f"{'tetradrill ' + w + ' p99.9':>24}{'ratio':>8}" for w in works))
for row in rounds:
    line = f"{row['round']:<7}{row['cyclictest']['p999']:>18.1f}"
    for w in works:
        q = row[f"ratio_{w}"]
        line += f"{row['tetradrill_' + w]['p999']:>24.1f}{q if q is not None else float('nan'):>8.2f}"
    print(line)

stats = {}
for w in works:
    ratios = [row[f"ratio_{w}"] for row in rounds if row[f"ratio_{w}"] is not None]
    if ratios:
        stats[w] = quartiles(ratios)
        s = stats[w]
        print(f"p99.9 ratio tetradrill ({w}) / cyclictest over {len(ratios)} rounds: median {s['median']:.2f}, "
              f"min {s['min']:.2f}, max {s['max']:.2f}, IQR {s['q1']:.2f}-{s['q3']:.2f} (target: median <= 1.20)")

print(f"\n{'wake-up latency us, median of rounds':<38}{'p50':>8}{'p99':>8}{'p99.9':>8}{'max':>9}")
medians = {}
for name in ["cyclictest"] + works:
    key = name if name == "cyclictest" else f"tetradrill_{name}"
    medians[name] = {m: quartiles([row[key][m] for row in rounds])["median"]
                     for m in ("p50", "p99", "p999", "max")}
    label = name if name == "cyclictest" else f"tetradrill ({name})"
    r = medians[name]
    print(f"{label:<38}{r['p50']:>8.1f}{r['p99']:>8.1f}{r['p999']:>8.1f}{r['max']:>9.1f}")

json.dump({"segment_seconds": secs, "pairs": pairs,
           "rounds": rounds, "p999_ratio": stats, "median_of_rounds": medians},
          open(f"{out}/../latency-vs-cyclictest.json", "w"), indent=2)
PY
