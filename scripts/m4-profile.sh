#!/usr/bin/env bash
# An instruction profile of the Cortex-M4 firmware's ticks FROM..TO under QEMU (docs/PORTING.md,
# "Profiling on the M4"): builds the firmware with TETRADRILL_PROFILE_FROM=FROM and
# TETRADRILL_TICKS=TO, runs it with QEMU's execution log piped into m4_profile (benches), and
# prints instructions by phase of the step, by core function and by source line.
#
#   scripts/m4-profile.sh FROM TO        # e.g. 4341 4342: the worst tick of builtin:firmware
#
# Extra build settings pass through the environment (TETRADRILL_BUDGET,
# TETRADRILL_CONTACT_NODES). About a minute for a run to tick 4342 (QEMU logs every block).
# Exit status: 0, 1 when a build or the profile fails, 2 for bad arguments.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
from="${1:-}"; to="${2:-}"
if ! [[ "$from" =~ ^[0-9]+$ && "$to" =~ ^[0-9]+$ ]] || [ "$to" -le "$from" ]; then
  echo "m4-profile: usage: scripts/m4-profile.sh FROM TO (whole numbers, FROM < TO)" >&2
  exit 2
fi
command -v qemu-system-arm >/dev/null || { echo "m4-profile: qemu-system-arm not found (apt-get install qemu-system-arm)" >&2; exit 1; }
command -v llvm-addr2line >/dev/null || { echo "m4-profile: llvm-addr2line not found (apt-get install llvm)" >&2; exit 1; }
target="${M4_PROFILE_TARGET:-$root/target/m4-profile}"

echo "== firmware: build (profile from tick $from, $to ticks)" >&2
(cd "$root/ports/mps2-an386" && TETRADRILL_PROFILE_FROM="$from" TETRADRILL_TICKS="$to" \
  cargo build --release --quiet --target-dir "$target")
elf="$target/thumbv7em-none-eabihf/release/tetradrill-mps2-an386"
echo "== profiler: build" >&2
(cd "$root" && cargo build --release --quiet -p tetradrill-benches --bin m4_profile)
prof="${CARGO_TARGET_DIR:-$root/target}/release/m4_profile"

echo "== run under QEMU with the execution log" >&2
out="$(mktemp)"
trap 'rm -f "$out"' EXIT
qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -icount shift=10,sleep=off \
  -no-reboot -nographic -kernel "$elf" \
  -d in_asm,exec,nochain -D /dev/stderr </dev/null 2>&1 >"$out" | "$prof" --elf "$elf"
grep -E '^(force_digest|instructions_per_tick_max|settings)' "$out" | tr -d '\r' >&2 || true
