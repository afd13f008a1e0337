#!/usr/bin/env bash
# Worst-case timing (issue #9 item 2): the adversarial scenarios of
# benches/src/bin/worst_case.rs, first natively (host time per tick: max, p99.9, p99, mean over
# TICKS ticks each), then each scenario under callgrind for instructions per tick.
#
# Usage: scripts/worst-case.sh [TICKS [CG_TICKS]]
#   TICKS     native ticks per scenario (default 100000; the documented full run, ~20 min)
#   CG_TICKS  ticks per scenario under callgrind (default 2000; 0 skips callgrind)
# Env: TETRADRILL_MESHES (default tests/data/meshes), CARGO_TARGET_DIR, WORST_OUT (output
#   folder, default target/worst-case), WORST_ONLY (one scenario name).
#
# Instructions per tick, how: the harness does each tick in one `#[inline(never)]` function
# (`worst_case::drill_tick`, `pen_tick`, `servo_tick`). callgrind runs with collection off at
# start and toggled on only inside that function (`--toggle-collect=worst_case::drill_tick`), and dumps its counters
# after every call (`--dump-after`), so dump k holds exactly the instructions of tick k
# (set-up, the pose search and the timing code are never counted). The script reads the
# `totals:` line of each dump and prints mean, p99 and max instructions per tick.
set -euo pipefail

ticks=${1:-100000}
cg_ticks=${2:-2000}
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
export TETRADRILL_MESHES=${TETRADRILL_MESHES:-$root/tests/data/meshes}
[ -d "$TETRADRILL_MESHES" ] || { echo "worst-case.sh: no meshes at $TETRADRILL_MESHES (set TETRADRILL_MESHES)" >&2; exit 2; }
case $ticks in ''|*[!0-9]*) echo "worst-case.sh: TICKS must be a whole number, not '$ticks'" >&2; exit 2;; esac
case $cg_ticks in ''|*[!0-9]*) echo "worst-case.sh: CG_TICKS must be a whole number, not '$cg_ticks'" >&2; exit 2;; esac

target=${CARGO_TARGET_DIR:-$root/target}
out=${WORST_OUT:-$target/worst-case}
mkdir -p "$out"
cargo build --release --quiet -p tetradrill-benches --bin worst_case
bin=$target/release/worst_case
[ -x "$bin" ] || { echo "worst-case.sh: no harness binary at $bin" >&2; exit 2; }

scenarios="burr-cow pen-teddy pen-teddy-servo drill-teddy-b1 drill-teddy-bdefault drill-teddy-bmax"
if [ -n "${WORST_ONLY:-}" ]; then scenarios=$WORST_ONLY; fi

echo "== host time per tick, $ticks ticks each ($(nproc) cores, load: $(cut -d' ' -f1-3 /proc/loadavg)) =="
{
  echo "| scenario | ticks | mean | p99 | p99.9 | max | counters |"
  echo "|---|---|---|---|---|---|---|"
} >"$out/host.md"
for s in $scenarios; do
  "$bin" --ticks "$ticks" --only "$s" | grep '^| [a-z]' | grep -v '^| scenario' | tee -a "$out/host.md"
done

[ "$cg_ticks" -gt 0 ] || exit 0
command -v valgrind >/dev/null || { echo "worst-case.sh: valgrind not found (apt-get install valgrind)" >&2; exit 2; }
echo "== instructions per tick (callgrind, $cg_ticks ticks each, one dump per tick) =="
echo "| scenario | ticks counted | mean Ir | p99 Ir | max Ir (tick) |" | tee "$out/callgrind.md"
echo "|---|---|---|---|---|" | tee -a "$out/callgrind.md"
for s in $scenarios; do
  d=$out/cg-$s
  rm -rf "$d"
  mkdir -p "$d"
  fn=worst_case::drill_tick
  [ "$s" = pen-teddy ] && fn=worst_case::pen_tick
  [ "$s" = pen-teddy-servo ] && fn=worst_case::servo_tick
  # Exact names: valgrind 3.19 matched the toggle but not the dump with a wildcard pattern.
  valgrind --tool=callgrind --callgrind-out-file="$d/cg.out" \
    --collect-atstart=no --toggle-collect="$fn" \
    --dump-after="$fn" --dump-instr=no --compress-strings=no \
    "$bin" --ticks "$cg_ticks" --only "$s" >"$d/harness.txt" 2>"$d/valgrind.log"
  # One file per dump: cg.out.1, cg.out.2, ... (cg.out itself holds what is left at exit).
  # Each has a `totals: N` line (events: Ir). Sort by dump number for the tick index.
  find "$d" -name 'cg.out.*' | awk -F. '{print $NF "\t" $0}' | sort -n | cut -f2 |
    xargs awk '/^totals:/ {print $2}' >"$d/ir-per-tick.txt"
  n=$(wc -l <"$d/ir-per-tick.txt")
  if [ "$n" -eq 0 ]; then
    echo "| $s | 0 | - | - | - (see $d/valgrind.log) |" | tee -a "$out/callgrind.md"
  else
    k=$(( (99 * n + 99) / 100 ))  # nearest rank
    p99=$(sort -n "$d/ir-per-tick.txt" | sed -n "${k}p")
    awk -v name="$s" -v n="$n" -v p99="$p99" '
      { sum += $1; if ($1 > max) { max = $1; at = NR } }
      END { printf "| %s | %d | %.0f | %d | %d (tick %d) |\n", name, n, sum / n, p99, max, at - 1 }
    ' "$d/ir-per-tick.txt" | tee -a "$out/callgrind.md"
  fi
  # Keep only the per-tick numbers, not thousands of dump files.
  find "$d" -name 'cg.out.*' -delete
done
echo "worst-case.sh: tables in $out/host.md and $out/callgrind.md"
