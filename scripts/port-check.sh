#!/usr/bin/env bash
# The Cortex-M4 port check (docs/PORTING.md): builds the mps2-an386 firmware, runs it under
# QEMU, runs the host's `replay --scenario builtin:firmware` over the same ticks, and compares
# the force digests. Prints both digests and the firmware's instruction counts per tick.
#
#   scripts/port-check.sh [--ticks N] [--max-instructions M]
#
# --max-instructions M also fails the check when the worst tick (simulate + servo_force) took
# more than M instructions (issue #8's target is 100000 for the whole scenario).
#
# Exit status: 0 when the digests match (and the worst tick is within M); 1 when they differ,
# the worst tick is over M, the firmware fails (panic, fault, non-zero semihosting exit,
# timeout) or a build fails; 2 for bad arguments. Honours CARGO_TARGET_DIR for the host
# build (default: the workspace's target/); the firmware builds in ports/mps2-an386/target.
# PORT_CHECK_TIMEOUT (seconds, default 900) bounds the QEMU run.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
port="$root/ports/mps2-an386"
ticks=""
max_instr=""
while [ $# -gt 0 ]; do
  case "$1" in
    --ticks) [ $# -ge 2 ] || { echo "port-check: --ticks needs a number" >&2; exit 2; }; ticks="$2"; shift 2 ;;
    --ticks=*) ticks="${1#--ticks=}"; shift ;;
    --max-instructions) [ $# -ge 2 ] || { echo "port-check: --max-instructions needs a number" >&2; exit 2; }; max_instr="$2"; shift 2 ;;
    --max-instructions=*) max_instr="${1#--max-instructions=}"; shift ;;
    -h|--help) sed -n '2,16p' "$0"; exit 0 ;;
    *) echo "port-check: unknown argument '$1' (expected --ticks N, --max-instructions M)" >&2; exit 2 ;;
  esac
done
if [ -n "$ticks" ] && ! [[ "$ticks" =~ ^[0-9]+$ ]]; then
  echo "port-check: --ticks takes a whole number, not '$ticks'" >&2; exit 2
fi
if [ -n "$max_instr" ] && ! [[ "$max_instr" =~ ^[0-9]+$ ]]; then
  echo "port-check: --max-instructions takes a whole number, not '$max_instr'" >&2; exit 2
fi
command -v qemu-system-arm >/dev/null || { echo "port-check: qemu-system-arm not found (apt-get install qemu-system-arm)" >&2; exit 1; }

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

echo "== firmware: build (thumbv7em-none-eabihf, release)"
# Its own target dir, whatever CARGO_TARGET_DIR says (that one is for the host build).
(cd "$port" && TETRADRILL_TICKS="$ticks" cargo build --release --quiet --target-dir "$port/target")
elf="$port/target/thumbv7em-none-eabihf/release/tetradrill-mps2-an386"
if command -v llvm-size >/dev/null; then llvm-size "$elf"; fi

echo "== firmware: run under QEMU (mps2-an386, cortex-m4, -icount shift=10)"
set +e
timeout "${PORT_CHECK_TIMEOUT:-900}" qemu-system-arm -machine mps2-an386 -cpu cortex-m4 \
  -icount shift=10 -semihosting-config enable=on,target=native -nographic -kernel "$elf" \
  </dev/null >"$work/fw.txt" 2>&1
fw_rc=$?
set -e
cat "$work/fw.txt"
if [ "$fw_rc" != 0 ]; then
  echo "port-check: FAIL: the firmware exited with status $fw_rc (124 = timeout)" >&2
  exit 1
fi
fw_digest="$(sed -n 's/^force_digest=\([0-9a-f]\{16\}\)\r\{0,1\}$/\1/p' "$work/fw.txt")"
fw_ticks="$(sed -n 's/^ticks=\([0-9]*\)\r\{0,1\}$/\1/p' "$work/fw.txt")"
[ -n "$fw_digest" ] && [ -n "$fw_ticks" ] || { echo "port-check: FAIL: no force_digest/ticks line from the firmware" >&2; exit 1; }

echo "== host: build and replay builtin:firmware over $fw_ticks ticks"
(cd "$root" && cargo build --release --quiet -p tetradrill)
host_bin="${CARGO_TARGET_DIR:-$root/target}/release/tetradrill"
"$host_bin" replay --scenario builtin:firmware --ticks "$fw_ticks" --quiet --json "$work/host.json"
host_digest="$(grep -o '"force_digest": *"[0-9a-f]*"' "$work/host.json" | grep -o '[0-9a-f]\{16\}')"
host_ticks="$(grep -o '"ticks": *[0-9]*' "$work/host.json" | head -n1 | grep -o '[0-9]*$')"

echo "== result"
echo "firmware: force_digest=$fw_digest ticks=$fw_ticks"
echo "host:     force_digest=$host_digest ticks=$host_ticks"
grep -E '^(instructions_per_tick_|simulate_instructions_|servo_force_instructions_)' "$work/fw.txt" | tr -d '\r'
if [ "$fw_digest" != "$host_digest" ] || [ "$fw_ticks" != "$host_ticks" ]; then
  echo "port-check: FAIL: the firmware and the host disagree" >&2
  exit 1
fi
if [ -n "$max_instr" ]; then
  worst="$(sed -n 's/^instructions_per_tick_max=\([0-9]*\)\r\{0,1\}$/\1/p' "$work/fw.txt")"
  at="$(sed -n 's/^instructions_per_tick_max_at=\([0-9]*\)\r\{0,1\}$/\1/p' "$work/fw.txt")"
  [ -n "$worst" ] || { echo "port-check: FAIL: no instructions_per_tick_max line from the firmware" >&2; exit 1; }
  if [ "$worst" -gt "$max_instr" ]; then
    echo "port-check: FAIL: worst tick $worst instructions (tick $at), over the $max_instr allowed" >&2
    exit 1
  fi
  echo "port-check: worst tick $worst instructions (tick $at), within $max_instr"
fi
echo "port-check: OK: bit-identical forces on x86-64 and Cortex-M4F"
