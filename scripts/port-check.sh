#!/usr/bin/env bash
# The port check (docs/PORTING.md): builds the RTIC firmware for a Cortex-M4 (QEMU mps2-an386)
# or a Cortex-M7 (mps2-an500), runs it under QEMU, runs the host's `replay` of the same
# scenario over the same ticks, and compares the force digests. Prints the firmware's report,
# then one `key=value` line each: force_digest, servo_latency_instructions_max,
# sim_step_instructions_max, deadline_misses, stack_max_bytes, flash_bytes, ram_bytes.
#
#   scripts/port-check.sh [--target m4|m7|m7sp] [--scenario block|cow|regions|soft|tooth] [--ticks N]
#                         [--max-instructions M] [--max-stack BYTES] [--garbage]
#                         [--inject panic|hardfault|stall|late [--inject-tick N]]
#
# --scenario block (default) is the host's builtin:firmware, cow is builtin:firmware-cow, regions
# is builtin:firmware-regions (the block with a hard shell and a soft core), soft is
# builtin:firmware-soft (the block as a soft body, its step spread over the ticks of each cycle),
# tooth is builtin:firmware-tooth (the premolar's access cavity through enamel and dentin into
# the pulp).
# --max-instructions M also fails the check when the worst tick (simulation step, the soft
# body's share on soft, and the servo tick) took more than M instructions.
# --max-stack BYTES also fails the check when the stack's high-water mark (the firmware paints
# the stack at reset and finds the deepest word it lost; stack_max_bytes) is above BYTES.
# --garbage builds the firmware with its `garbage` feature: at reset, before anything
# initialises memory, RAM and the PSRAM statics are filled with 0xa5a5a5a5, so the digest
# matches only if nothing reads memory the firmware or the runtime did not initialise.
# --inject KIND builds the firmware with a fault armed at servo tick N (--inject-tick, default
# 2000, where the block's force is non-zero on every axis): a panic, a hard fault, or a stall
# (the servo spins without feeding the watchdog, whose NMI must stop it). The fault handler
# zeroes the motor outputs, then reads them back 20 times over two servo periods; the check
# prints force_after_fault_n= (the samples with an output still live) and passes when the
# expected handler ran (fault=panic, hardfault or watchdog), the force at the fault was not
# zero, and force_after_fault_n=0. No host run.
# --inject late is not a fault: the simulation step released at tick N spins 15 servo periods
# first, so the servo's contacts arrive late; the check reads the deadline-miss policy from
# the report (late_first_run_force_n=: the last on-time force, then the force written on each
# late tick) and passes when the first late tick held that force, the next ten ramped it down
# linearly (each within 0.1 % + 1e-4 N of before * (10 - k) / 10), it was zero from the
# eleventh on, and the run ended normally (exit_status=0) with its misses counted.
#
# The firmware prints over UART0 (stdio) and ends each run with a reset, which -no-reboot
# turns into QEMU's exit; its last line is exit_status=0, or exit_status=1 after a panic, a
# fault or a refusal (the motors stopped first).
# Exit status: 0 when the digests match, no deadline was missed (and the worst tick is within
# M, the stack within BYTES; with --inject, when the outputs stayed zero after the fault); 1
# when they differ, a deadline was missed, the worst tick is over M, the stack over BYTES,
# the firmware fails (panic, fault, stack overflow, exit_status other than 0, timeout), an
# injected fault left an output live, or a build fails; 2 for bad arguments.
# Honours CARGO_TARGET_DIR for the host build (default: the workspace's target/); the firmware
# builds in ports/mps2-an386/target (target/m7 for the M7). PORT_CHECK_TIMEOUT (seconds,
# default 900) bounds the QEMU run.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
port="$root/ports/mps2-an386"
ticks=""
max_instr=""
max_stack=""
garbage=""
inject=""
inject_tick="2000"
target="m4"
scenario="block"
need() { [ "$2" -ge 2 ] || { echo "port-check: $1 needs a value" >&2; exit 2; }; }
while [ $# -gt 0 ]; do
  case "$1" in
    --ticks) need "$1" $#; ticks="$2"; shift 2 ;;
    --ticks=*) ticks="${1#--ticks=}"; shift ;;
    --max-instructions) need "$1" $#; max_instr="$2"; shift 2 ;;
    --max-instructions=*) max_instr="${1#--max-instructions=}"; shift ;;
    --max-stack) need "$1" $#; max_stack="$2"; shift 2 ;;
    --max-stack=*) max_stack="${1#--max-stack=}"; shift ;;
    --garbage) garbage=1; shift ;;
    --inject) need "$1" $#; inject="$2"; shift 2 ;;
    --inject=*) inject="${1#--inject=}"; shift ;;
    --inject-tick) need "$1" $#; inject_tick="$2"; shift 2 ;;
    --inject-tick=*) inject_tick="${1#--inject-tick=}"; shift ;;
    --target) need "$1" $#; target="$2"; shift 2 ;;
    --target=*) target="${1#--target=}"; shift ;;
    --scenario) need "$1" $#; scenario="$2"; shift 2 ;;
    --scenario=*) scenario="${1#--scenario=}"; shift ;;
    -h|--help) sed -n '2,44p' "$0"; exit 0 ;;
    *) echo "port-check: unknown argument '$1' (expected --target m4|m7|m7sp, --scenario block|cow|regions|soft|tooth, --ticks N, --max-instructions M, --max-stack BYTES, --garbage, --inject panic|hardfault|stall|late, --inject-tick N)" >&2; exit 2 ;;
  esac
done
if [ -n "$ticks" ] && ! [[ "$ticks" =~ ^[0-9]+$ ]]; then
  echo "port-check: --ticks takes a whole number, not '$ticks'" >&2; exit 2
fi
if [ -n "$max_instr" ] && ! [[ "$max_instr" =~ ^[0-9]+$ ]]; then
  echo "port-check: --max-instructions takes a whole number, not '$max_instr'" >&2; exit 2
fi
if [ -n "$max_stack" ] && ! [[ "$max_stack" =~ ^[0-9]+$ ]]; then
  echo "port-check: --max-stack takes a whole number of bytes, not '$max_stack'" >&2; exit 2
fi
case "$inject" in
  "") ;;
  panic) expect_fault="panic" ;;
  hardfault) expect_fault="hardfault" ;;
  stall) expect_fault="watchdog" ;;
  late) expect_fault="" ;;
  *) echo "port-check: --inject takes panic, hardfault, stall or late, not '$inject'" >&2; exit 2 ;;
esac
if ! [[ "$inject_tick" =~ ^[0-9]+$ ]]; then
  echo "port-check: --inject-tick takes a whole number, not '$inject_tick'" >&2; exit 2
fi
case "$target" in
  m4) machine="mps2-an386"; cpu="cortex-m4"; features=""; tdir="$port/target"; rustflags="" ;;
  m7) machine="mps2-an500"; cpu="cortex-m7"; features="m7"; tdir="$port/target/m7"
      rustflags="-C target-cpu=cortex-m7" ;;
  # A Cortex-M7 whose FPU does single precision only (fpv5-sp-d16): rustc's documented flags
  # for it (the thumbv7em-none-eabihf platform page); QEMU's M7 runs the subset.
  m7sp) machine="mps2-an500"; cpu="cortex-m7"; features="m7"; tdir="$port/target/m7sp"
      rustflags="-C target-cpu=cortex-m7 -C target-feature=-fp64" ;;
  *) echo "port-check: --target takes m4, m7 or m7sp, not '$target'" >&2; exit 2 ;;
esac
[ -z "$garbage" ] || features="${features:+$features,}garbage"
[ -z "$features" ] || features="--features $features"
case "$scenario" in
  block) host_scenario="builtin:firmware"; fw_scenario="" ;;
  cow) host_scenario="builtin:firmware-cow"; fw_scenario="cow" ;;
  regions) host_scenario="builtin:firmware-regions"; fw_scenario="regions" ;;
  soft) host_scenario="builtin:firmware-soft"; fw_scenario="soft" ;;
  tooth) host_scenario="builtin:firmware-tooth"; fw_scenario="tooth" ;;
  *) echo "port-check: --scenario takes block, cow, regions, soft or tooth, not '$scenario'" >&2; exit 2 ;;
esac
command -v qemu-system-arm >/dev/null || { echo "port-check: qemu-system-arm not found (apt-get install qemu-system-arm)" >&2; exit 1; }

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

if [ -n "$fw_scenario" ]; then
  echo "== host: build, export the mesh blob the firmware includes"
  (cd "$root" && cargo build --release --quiet -p tetradrill)
fi
host_bin="${CARGO_TARGET_DIR:-$root/target}/release/tetradrill"
if [ "$scenario" = cow ]; then
  cow="${TETRADRILL_MESHES:-$root/tests/data/meshes}/models/spot_tetgen_q1.414.node"
  [ -f "$cow" ] || cow="$root/tests/data/meshes/models/spot_tetgen_q1.414.node"
  mkdir -p "$port/target/blobs"
  "$host_bin" export --firmware "$port/target/blobs/cow.tdb" --mesh "$cow" --quiet
  export TETRADRILL_BLOB="$port/target/blobs/cow.tdb"
fi
if [ "$scenario" = tooth ]; then
  tooth="${TETRADRILL_MESHES:-$root/tests/data/meshes}/models/tooth_premolar_gmsh.msh22.msh"
  [ -f "$tooth" ] || tooth="$root/tests/data/meshes/models/tooth_premolar_gmsh.msh22.msh"
  mkdir -p "$port/target/blobs"
  "$host_bin" export --firmware "$port/target/blobs/tooth.tdb" --mesh "$tooth" --quiet
  export TETRADRILL_BLOB="$port/target/blobs/tooth.tdb"
fi

echo "== firmware: build ($target, thumbv7em-none-eabihf, release, scenario $scenario${inject:+, $inject injected at tick $inject_tick})"
# Its own target dir, whatever CARGO_TARGET_DIR says (that one is for the host build); the
# rustflags add to .cargo/config.toml's (which links with link.x).
# shellcheck disable=SC2086
(cd "$port" && TETRADRILL_TICKS="$ticks" TETRADRILL_SCENARIO="$fw_scenario" \
  TETRADRILL_INJECT="$inject" TETRADRILL_INJECT_TICK="$inject_tick" \
  CARGO_TARGET_THUMBV7EM_NONE_EABIHF_RUSTFLAGS="$rustflags" \
  cargo build --release --quiet $features --target-dir "$tdir")
elf="$tdir/thumbv7em-none-eabihf/release/tetradrill-mps2-an386"
sizes="$(llvm-size "$elf" 2>/dev/null || arm-none-eabi-size "$elf")"
echo "$sizes"
read -r text data bss _ < <(echo "$sizes" | tail -n1)
# Double-precision FPU instructions in the image (`vadd.f64`, `vcvt.f64.f32`, ...): none may
# be there for a single-precision FPU, whose core would fault on them (UsageFault, NOCP).
f64_ops="$( (llvm-objdump -d --no-show-raw-insn --mcpu=cortex-m7 "$elf" 2>/dev/null || arm-none-eabi-objdump -d "$elf") \
  | grep -cE '\s(v[a-z0-9]+)\.(f64|[fsu]32\.f64|f64\.[fsu]32)\s' || true)"
echo "fpu_f64_instructions=$f64_ops"
if [ "$target" = m7sp ] && [ "$f64_ops" != 0 ]; then
  echo "port-check: FAIL: $f64_ops double-precision FPU instructions in a single-precision build" >&2
  exit 1
fi

echo "== firmware: run under QEMU ($machine, $cpu, -icount shift=10,sleep=off)"
set +e
timeout "${PORT_CHECK_TIMEOUT:-900}" qemu-system-arm -machine "$machine" -cpu "$cpu" \
  -icount shift=10,sleep=off -no-reboot -nographic -kernel "$elf" \
  </dev/null >"$work/fw.txt" 2>&1
fw_rc=$?
set -e
tr -d '\r' <"$work/fw.txt" >"$work/fw2.txt"; mv "$work/fw2.txt" "$work/fw.txt"
cat "$work/fw.txt"
if [ "$fw_rc" != 0 ]; then
  echo "port-check: FAIL: QEMU exited with status $fw_rc (124 = timeout)" >&2
  exit 1
fi
val() { sed -n "s/^$1=\\([0-9a-f]*\\)\$/\\1/p" "$work/fw.txt" | head -n1; }
exit_status="$(val exit_status)"
if [ "$inject" = late ]; then
  echo "== result"
  run="$(sed -n 's/^late_first_run_force_n=//p' "$work/fw.txt" | head -n1)"
  echo "deadline_misses=$(val deadline_misses)"
  echo "late_ticks_held=$(val late_ticks_held)"
  echo "late_ticks_ramped=$(val late_ticks_ramped)"
  echo "late_ticks_longest_run=$(val late_ticks_longest_run)"
  echo "late_first_run_force_n=$run"
  [ "$exit_status" = 0 ] || { echo "port-check: FAIL: the run did not end normally (exit_status=${exit_status:-none})" >&2; exit 1; }
  if ! echo "$run" | awk -F, -v hold=1 -v ramp=10 '
    {
      before = $1
      if (before <= 0.01) { print "the force before the late ticks was zero: the check would prove nothing"; exit 1 }
      if (NF < 1 + hold + ramp) { print "only " NF - 1 " late ticks recorded, fewer than the hold and the ramp"; exit 1 }
      for (k = 1; k < NF; k++) {
        want = (k <= hold) ? before : ((k - hold >= ramp) ? 0 : before * (ramp - (k - hold)) / ramp)
        got = $(k + 1); d = got - want; if (d < 0) d = -d
        if (d > 0.001 * want + 1e-4) { print "late tick " k ": " got " N written, the policy says " want; exit 1 }
      }
    }'; then
    echo "port-check: FAIL: the deadline-miss policy did not hold the force, then ramp it to zero" >&2
    exit 1
  fi
  echo "port-check: OK: late steps at tick $inject_tick: the force held one tick, ramped to zero over ten, the misses counted"
  exit 0
fi
if [ -n "$inject" ]; then
  fault="$(sed -n 's/^fault=\([a-z]*\)$/\1/p' "$work/fw.txt" | head -n1)"
  at_fault="$(sed -n 's/^force_at_fault=//p' "$work/fw.txt" | head -n1)"
  after_n="$(val force_after_fault_n)"
  echo "== result"
  echo "fault=$fault"
  echo "force_at_fault=$at_fault"
  echo "force_after_fault_samples=$(val force_after_fault_samples)"
  echo "force_after_fault_n=$after_n"
  if [ "$fault" != "$expect_fault" ]; then
    echo "port-check: FAIL: expected fault=$expect_fault, the firmware reported '${fault:-nothing}'" >&2
    exit 1
  fi
  if [ -z "$at_fault" ] || [ "$(echo "$at_fault" | tr -d ' 0.-')" = "" ]; then
    echo "port-check: FAIL: the force was zero at the fault (tick $inject_tick): the check would prove nothing" >&2
    exit 1
  fi
  if [ "$after_n" != 0 ]; then
    echo "port-check: FAIL: a motor output was live in ${after_n:-?} samples after the fault" >&2
    exit 1
  fi
  echo "port-check: OK: $inject at tick $inject_tick: the $expect_fault handler zeroed the motor outputs and they stayed zero"
  exit 0
fi
if [ "$exit_status" != 0 ]; then
  echo "port-check: FAIL: the firmware ended with exit_status=${exit_status:-none}" >&2
  exit 1
fi
fw_digest="$(val force_digest)"
fw_ticks="$(val ticks)"
[ -n "$fw_digest" ] && [ -n "$fw_ticks" ] || { echo "port-check: FAIL: no force_digest/ticks line from the firmware" >&2; exit 1; }

echo "== host: build and replay $host_scenario over $fw_ticks ticks"
(cd "$root" && cargo build --release --quiet -p tetradrill)
"$host_bin" replay --scenario "$host_scenario" --ticks "$fw_ticks" --quiet --json "$work/host.json"
host_digest="$(grep -o '"force_digest": *"[0-9a-f]*"' "$work/host.json" | grep -o '[0-9a-f]\{16\}')"
host_ticks="$(grep -o '"ticks": *[0-9]*' "$work/host.json" | head -n1 | grep -o '[0-9]*$')"

echo "== result"
echo "firmware: force_digest=$fw_digest ticks=$fw_ticks"
echo "host:     force_digest=$host_digest ticks=$host_ticks"
echo "force_digest=$fw_digest"
echo "servo_latency_instructions_max=$(val servo_latency_instructions_max)"
echo "sim_step_instructions_max=$(val sim_step_instructions_max)"
stack="$(val stack_max_bytes)"
echo "stack_max_bytes=$stack"
misses="$(val deadline_misses)"
echo "deadline_misses=$misses"
echo "flash_bytes=$((text + data))"
echo "ram_bytes=$((data + bss))"
if [ "$fw_digest" != "$host_digest" ] || [ "$fw_ticks" != "$host_ticks" ]; then
  echo "port-check: FAIL: the firmware and the host disagree" >&2
  exit 1
fi
if [ "$misses" != 0 ]; then
  echo "port-check: FAIL: $misses deadline misses" >&2
  exit 1
fi
if [ -n "$max_instr" ]; then
  worst="$(val instructions_per_tick_max)"
  at="$(val instructions_per_tick_max_at)"
  [ -n "$worst" ] || { echo "port-check: FAIL: no instructions_per_tick_max line from the firmware" >&2; exit 1; }
  if [ "$worst" -gt "$max_instr" ]; then
    echo "port-check: FAIL: worst tick $worst instructions (tick $at), over the $max_instr allowed" >&2
    exit 1
  fi
  echo "port-check: worst tick $worst instructions (tick $at), within $max_instr"
fi
if [ -n "$max_stack" ]; then
  [ -n "$stack" ] || { echo "port-check: FAIL: no stack_max_bytes line from the firmware" >&2; exit 1; }
  if [ "$stack" -gt "$max_stack" ]; then
    echo "port-check: FAIL: stack high-water mark $stack bytes, over the $max_stack allowed" >&2
    exit 1
  fi
  echo "port-check: stack high-water mark $stack bytes, within $max_stack"
fi
echo "port-check: OK: bit-identical forces on x86-64 and the $cpu, no deadline missed"
