#!/usr/bin/env bash
# Soak test: the simulated device wanders over the teddy with the drill on, at 1 kHz, through
# the real-time pipeline (`tetradrill run --device sim --trace wander:SEED`, headless), for
# MINUTES (default 10; `20s` for seconds, `1h` for hours: a training run's length). The
# run's resident memory (VmRSS) is sampled every
# few seconds; after a warm-up it must not grow beyond a small tolerance. The run must end with
# exit 0 and a valid final state (`valid` in its JSON, the core's validate()); overruns and
# saturations are reported.
#
#   scripts/soak.sh [MINUTES|SECONDSs|HOURSh]      e.g. scripts/soak.sh 1h
#
# Environment: TETRADRILL_MESHES (the meshes folder; default tests/data/meshes),
# TETRADRILL_BIN (a built binary; default: build the release binary with cargo),
# SOAK_SEED (the wander's seed, default 1), SOAK_OUT (where the JSON, the log and the RSS
# samples go; default target/soak), SOAK_TOLERANCE_KB (allowed growth after warm-up; default
# 1024 KiB or 1% of the RSS at the end of warm-up, whichever is larger),
# SOAK_ARGS (extra flags for `run`, e.g. --no-rt), SOAK_TOOL (the tool, default sphere:0.03;
# `mesh:FILE` soaks a tet-mesh tool's contact pipeline, e.g. with SOAK_ARGS=--tool-scale 10),
# SOAK_STOP (`duration`, the default: the run ends by `--duration`; `signal`: the run has no
# end of its own and gets SIGINT after the time, as a user's Ctrl-C; it must then stop
# cleanly: exit 0, `stop_reason` signal, zero force last written).
set -euo pipefail
cd "$(dirname "$0")/.."

arg=${1:-10}
case "$arg" in
  *s) seconds=${arg%s} ;;
  *h) seconds=$(awk -v h="${arg%h}" 'BEGIN { printf "%.0f", h * 3600 }') ;;
  *) seconds=$(awk -v m="$arg" 'BEGIN { printf "%.0f", m * 60 }') ;;
esac
if ! [[ "$seconds" =~ ^[0-9]+$ ]] || [ "$seconds" -lt 20 ]; then
  echo "soak: the duration must be at least 20 s (got '$arg')" >&2
  exit 2
fi

meshes=${TETRADRILL_MESHES:-tests/data/meshes}
teddy=$meshes/models/teddy_cgalbear_tetgen_q1.414.node
[ -f "$teddy" ] || { echo "soak: no teddy at $teddy (set TETRADRILL_MESHES)" >&2; exit 2; }
target=${CARGO_TARGET_DIR:-target}
if [ -z "${TETRADRILL_BIN:-}" ]; then
  cargo build --release --quiet -p tetradrill
  bin=$target/release/tetradrill
else
  bin=$TETRADRILL_BIN
fi
out=${SOAK_OUT:-$target/soak}
mkdir -p "$out"
seed=${SOAK_SEED:-1}

# Samples: every 5 s for long runs, every second for short ones. Warm-up: the first 10% of the
# run, at least 10 s (the mesh is loaded, the storage allocated and touched, the first
# drilling done). The last two intervals are left out (the run's end: the summary and the
# JSON).
interval=5
[ "$seconds" -lt 120 ] && interval=1
warm=$(( seconds / 10 ))
[ "$warm" -lt 10 ] && warm=10
[ "$warm" -gt $(( seconds - 3 * interval )) ] && warm=$(( seconds - 3 * interval ))
until=$(( seconds - 2 * interval ))

tool=${SOAK_TOOL:-sphere:0.03}
stop=${SOAK_STOP:-duration}
case "$stop" in
  duration) length=(--duration "$seconds") ;;
  signal) length=() ;;
  *) echo "soak: SOAK_STOP must be duration or signal (got '$stop')" >&2; exit 2 ;;
esac
echo "soak: ${seconds} s, teddy, wander:$seed, tool $tool, drill on, ends by $stop; RSS every ${interval} s after ${warm} s of warm-up"
rm -f "$out/soak.json"
# shellcheck disable=SC2086
"$bin" run --device sim --mesh "$teddy" --trace "wander:$seed" --tool "$tool" \
  --max-depth 3 "${length[@]}" --headless --quiet --json "$out/soak.json" \
  ${SOAK_ARGS:-} >"$out/soak.log" 2>&1 &
pid=$!
start=$(date +%s.%N)
signalled=0
: >"$out/rss.tsv"
while kill -0 "$pid" 2>/dev/null; do
  rss=$(awk '/^VmRSS:/ { print $2 }' "/proc/$pid/status" 2>/dev/null || true)
  now=$(date +%s.%N)
  elapsed=$(awk -v a="$now" -v b="$start" 'BEGIN { print a - b }')
  [ -n "$rss" ] && printf '%.1f\t%s\n' "$elapsed" "$rss" >>"$out/rss.tsv"
  if [ "$stop" = signal ] && [ "$signalled" = 0 ] && awk -v e="$elapsed" -v s="$seconds" 'BEGIN { exit !(e >= s) }'; then
    kill -INT "$pid" 2>/dev/null || true
    signalled=1
    continue
  fi
  sleep "$interval"
done
set +e
wait "$pid"
rc=$?
set -e
cat "$out/soak.log"
if [ "$rc" != 0 ]; then
  echo "soak: FAILED: the run exited with status $rc" >&2
  exit 1
fi

# Memory: the RSS at the end of warm-up against the largest RSS after it.
read -r base peak last n < <(awk -v w="$warm" -v u="$until" '
  $1 >= w && $1 <= u { if (!n) base = $2; if ($2 > peak) peak = $2; last = $2; n++ }
  END { print base + 0, peak + 0, last + 0, n + 0 }' "$out/rss.tsv")
first=$(awk 'NR == 1 { print $2 }' "$out/rss.tsv")
tol=${SOAK_TOLERANCE_KB:-$(( base / 100 > 1024 ? base / 100 : 1024 ))}
growth=$(( peak - base ))

field() { # field KEY: a top-level number or boolean of the run's JSON
  python3 -c "import json,sys; d=json.load(open(sys.argv[1])); v=d; [v := v[k] for k in sys.argv[2].split('.')]; print(str(v).lower() if isinstance(v, bool) else v)" "$out/soak.json" "$1"
}
ticks=$(field ticks)
reason=$(field stop_reason)
last_force=$(field force.last_written_n)
overruns=$(field overruns)
valid=$(field valid)
sat=$(field saturations.total)

echo "soak: RSS first ${first} KiB; after warm-up ${base} KiB, peak ${peak} KiB, last ${last} KiB over ${n} samples: growth ${growth} KiB (tolerance ${tol} KiB)"
echo "soak: ${ticks} ticks, ${overruns} overruns, saturations ${sat}, final state valid: ${valid}; stopped by ${reason}, last force written ${last_force} N"
echo "soak: samples in $out/rss.tsv, summary in $out/soak.json"
fail=0
if [ "$n" -lt 3 ]; then
  echo "soak: FAILED: only $n RSS samples after warm-up" >&2
  fail=1
fi
if [ "$growth" -gt "$tol" ]; then
  echo "soak: FAILED: resident memory grew by ${growth} KiB after warm-up" >&2
  fail=1
fi
if [ "$valid" != true ]; then
  echo "soak: FAILED: the final state is not valid" >&2
  fail=1
fi
if [ "$stop" = duration ] && [ "$ticks" -lt $(( seconds * 1000 )) ]; then
  echo "soak: FAILED: ${ticks} ticks of $(( seconds * 1000 ))" >&2
  fail=1
fi
# A signalled run started its servo after loading the teddy: most of the time, not all.
if [ "$stop" = signal ] && [ "$ticks" -lt $(( seconds * 1000 / 2 )) ]; then
  echo "soak: FAILED: only ${ticks} ticks in ${seconds} s" >&2
  fail=1
fi
if [ "$stop" = signal ] && [ "$reason" != signal ]; then
  echo "soak: FAILED: the run stopped by '${reason}', not the signal" >&2
  fail=1
fi
if [ "$last_force" != 0.0 ]; then
  echo "soak: FAILED: the last force written was ${last_force} N, not zero" >&2
  fail=1
fi
[ "$fail" = 0 ] && echo "soak: ok"
exit "$fail"
