#!/usr/bin/env bash
# Builds the STM32H743 board crate (ports/stm32h743, release, thumbv7em-none-eabihf) and prints
# its flash and the RAM of each of the chip's regions, one `key=value` line each:
# flash_bytes, ram_bytes_DTCM, ram_bytes_AXISRAM, ram_bytes_SRAM123, ram_bytes_SRAM4.
# Exit status 1 when the build fails or a region is over the chip's (the link already fails
# then; this says which), 0 otherwise.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
crate="$root/ports/stm32h743"
(cd "$crate" && cargo build --release --quiet)
elf="$crate/target/thumbv7em-none-eabihf/release/tetradrill-stm32h743"
sections="$(llvm-size -A -d "$elf" 2>/dev/null || arm-none-eabi-size -A -d "$elf")"
size_of() { echo "$sections" | awk -v s="$1" '$1 == s { print $2 }'; }
sum() { local t=0 n; for s in "$@"; do n="$(size_of "$s")"; t=$((t + ${n:-0})); done; echo "$t"; }
flash="$(sum .vector_table .text .rodata .data)"
fail=""
check() { # name used limit
  echo "ram_bytes_$1=$2"
  [ "$2" -le "$3" ] || fail="$fail $1 ($2 of $3 bytes)"
}
echo "flash_bytes=$flash"
[ "$flash" -le $((2048 * 1024)) ] || fail="$fail FLASH ($flash bytes)"
check DTCM "$(sum .data .bss .uninit .dtcm)" $((128 * 1024))
check AXISRAM "$(sum .axisram)" $((512 * 1024))
check SRAM123 "$(sum .sram123)" $((288 * 1024))
check SRAM4 "$(sum .sram4)" $((64 * 1024))
if [ -n "$fail" ]; then
  echo "board-size: FAIL: over the chip's region:$fail" >&2
  exit 1
fi
echo "board-size: OK: the STM32H743 board crate links within the chip's regions"
