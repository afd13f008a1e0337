#!/usr/bin/env bash
# The C examples over the C interface (docs/FFI.md), each checked against the host's replay.
#
#   scripts/c-example.sh              the host program: builds libtetradrill_ffi.a (profile
#                                     ffi), compiles examples/c/replay_demo.c with cc, runs it,
#                                     and compares its force_digest with
#                                     `tetradrill replay --scenario builtin:demo --json`'s; then
#                                     the same over libtetradrill_ffi.so; then
#                                     examples/c/soft_demo.c (the cow soft under the burr, whole
#                                     steps and spread over the ticks)
#   scripts/c-example.sh --cortex-m   the bare-metal program: the library for
#                                     thumbv7em-none-eabihf, examples/c/cortex_m linked with
#                                     arm-none-eabi-gcc, run under QEMU (mps2-an386, -icount)
#                                     with the servo in the SysTick interrupt over the
#                                     simulation's loop (prints servo=systick), compared
#                                     with `replay --scenario builtin:firmware`'s digest;
#                                     then the same with the block read in place from a
#                                     mesh blob in flash (`tetradrill export --firmware`);
#                                     then the block soft, its step spread over the ticks
#                                     (examples/c/soft_block.h), against the same set-up
#                                     on the host (examples/c/soft_firmware.c);
#                                     before the run, the calls into core's panic entry
#                                     points in the linked program are counted: above 0 fails
#   scripts/c-example.sh --tools      the tools with an orientation: builds libtetradrill_ffi.a,
#                                     compiles examples/c/drill_demo.c (the demo path with a
#                                     drill, force and torque out), runs it, and compares its
#                                     force_digest, removed_by_region and shaft figures with
#                                     `tetradrill replay --scenario builtin:demo --tool
#                                     drill:0.1:0.6:0.03 --json`'s; then examples/c/pen_demo.c
#                                     (the demo path with a tet-mesh tool), its digest and pen
#                                     figures against `replay --tool mesh:builtin:block:2
#                                     --tool-scale 0.2 --json`'s
#   scripts/c-example.sh --tsan       the two-thread program (examples/c/two_threads.c: the
#                                     servo at 1 kHz on one thread, the simulation on the
#                                     other) with the library and the program instrumented for
#                                     ThreadSanitizer, run for TSAN_SECONDS (default 10);
#                                     prints tsan_reports=N and fails above 0
#   scripts/c-example.sh --surface OUT.obj
#                                     the drilled surface: builds the library, compiles
#                                     examples/c/surface_demo.c, which replays builtin:demo
#                                     and keeps a mirror of its surface buffers updated only
#                                     from the reported slot ranges, writes the mirror's
#                                     triangles with their smooth normals to OUT.obj, and
#                                     compares them (any order, the same floats, each
#                                     corner's normal too) with `tetradrill replay --scenario
#                                     builtin:demo --surface`'s; prints `surface: N triangles,
#                                     equal to replay --surface (normals too)`
#
# Prints `force_digest=HEX` (the C program's) and both digests; where the C program prints
# `removed_by_region.LABEL=V` lines (the host program), they are compared too with the host's
# `removed_by_region` at the same six decimals. Exit status: 0 when they match; 1 when they
# differ or a build or run fails; 2 for bad arguments. Honours CARGO_TARGET_DIR
# (default: the workspace's target/) and TETRADRILL_BIN (default: the release build of
# `tetradrill`, built when missing). C_EXAMPLE_TIMEOUT (seconds, default 900) bounds the QEMU run.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
mode=host
obj=""
while [ $# -gt 0 ]; do
  case "$1" in
    --cortex-m) mode=cortex-m; shift ;;
    --tsan) mode=tsan; shift ;;
    --surface)
      [ $# -ge 2 ] || { echo "c-example: --surface needs a file name (OUT.obj)" >&2; exit 2; }
      mode=surface; obj="$2"; shift 2 ;;
    --tools) mode=tools; shift ;;
    -h|--help) sed -n "2,$(( $(grep -n '^set -euo' "$0" | cut -d: -f1) - 1 ))p" "$0"; exit 0 ;;
    *) echo "c-example: unknown argument '$1' (expected --cortex-m, --tools, --tsan or --surface OUT.obj)" >&2; exit 2 ;;
  esac
done
target_dir="${CARGO_TARGET_DIR:-$root/target}"
case "$target_dir" in /*) ;; *) target_dir="$root/$target_dir" ;; esac
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
cd "$root"

# The `tetradrill` binary: TETRADRILL_BIN, or the release build (built when missing).
host_bin() {
  local bin="${TETRADRILL_BIN:-}"
  if [ -z "$bin" ]; then
    cargo build --release --quiet -p tetradrill >&2
    bin="$target_dir/release/tetradrill"
  fi
  echo "$bin"
}

# The host's digest of a built-in scenario, from `replay --json` (more arguments after the
# scenario's name go to `replay`).
host_digest() {
  local bin name="$1"
  bin="$(host_bin)"
  shift
  "$bin" replay --scenario "builtin:$name" "$@" --quiet --json "$work/replay.json" >/dev/null \
    2>"$work/replay.err" || { cat "$work/replay.err" >&2; exit 1; }
  sed -n 's/.*"force_digest": *"\([0-9a-f]\{16\}\)".*/\1/p' "$work/replay.json" | head -1
}

# Compares the C program's output (file $1) with the host's digest of scenario $2 (more
# arguments go to `replay`).
compare() {
  local c_digest want out="$1"
  shift
  c_digest="$(sed -n 's/^force_digest=\([0-9a-f]\{16\}\)\r\{0,1\}$/\1/p' "$out")"
  want="$(host_digest "$@")"
  echo "C interface:  force_digest=$c_digest"
  echo "host replay:  force_digest=$want (replay --scenario builtin:$*)"
  if [ -z "$c_digest" ] || [ "$c_digest" != "$want" ]; then
    echo "c-example: FAIL: the digests differ" >&2
    exit 1
  fi
  echo "c-example: OK, the same digest"
  # The volume removed from each region, where the C program prints it.
  local c_regions host_regions
  c_regions="$(sed -n 's/\r$//; /^removed_by_region\./p' "$out")"
  [ -n "$c_regions" ] || return 0
  host_regions="$(sed -n '/"removed_by_region": *{/,/}/p' "$work/replay.json" |
    sed -n 's/^ *"\(-\{0,1\}[0-9]*\)": *\([-0-9.eE+]*\),\{0,1\}$/\1 \2/p' |
    awk '{ printf "removed_by_region.%s=%.6f\n", $1, $2 }')"
  if [ "$c_regions" != "$host_regions" ]; then
    echo "c-example: FAIL: removed_by_region differs; C:" >&2
    echo "$c_regions" >&2
    echo "host:" >&2
    echo "$host_regions" >&2
    exit 1
  fi
  echo "c-example: OK, the same removed_by_region ($(echo "$c_regions" | paste -sd' '))"
  # The drill's shaft figures, where the C program prints them (the host's JSON has more:
  # the walk's bound and cuts, which the C interface does not count).
  local c_shaft host_shaft
  c_shaft="$(sed -n 's/\r$//; /^shaft\./p' "$out")"
  [ -n "$c_shaft" ] || return 0
  host_shaft="$(sed -n '/"shaft": *{/,/}/p' "$work/replay.json" |
    sed -n 's/^ *"\([a-z_]*\)": *\([0-9]*\),\{0,1\}$/shaft.\1=\2/p' |
    grep -F -f <(echo "$c_shaft" | sed 's/=.*/=/'))"
  if [ "$c_shaft" != "$host_shaft" ]; then
    echo "c-example: FAIL: the shaft's figures differ; C:" >&2
    echo "$c_shaft" >&2
    echo "host:" >&2
    echo "$host_shaft" >&2
    exit 1
  fi
  echo "c-example: OK, the same shaft ($(echo "$c_shaft" | paste -sd' '))"
}

# Compares the pen's figures the C program printed (`pen.KEY=V` lines of file $1) with the
# `pen` of the last `replay --json`.
compare_pen() {
  local key value host_pen
  host_pen="$(sed -n '/"pen": *{/,/^  }/p' "$work/replay.json")"
  while IFS='=' read -r key value; do
    key="${key#pen.}"
    # A here-string, not a pipe: `grep -q` stops at its match, and under pipefail the echo
    # it leaves writing would fail the check now and then (SIGPIPE).
    if ! grep -q "^ *\"$key\": *$value,\{0,1\}\$" <<<"$host_pen"; then
      echo "c-example: FAIL: the pen's $key differs: C $value, host $(echo "$host_pen" |
        sed -n "s/^ *\"$key\": *\([^,]*\),\{0,1\}\$/\1/p")" >&2
      exit 1
    fi
  done < <(sed -n 's/\r$//; /^pen\./p' "$1")
  echo "c-example: OK, the same pen figures ($(sed -n 's/\r$//; s/^pen\.//p' "$1" | paste -sd' '))"
}

# The triangles of an OBJ file, one canonical line each, sorted (scripts/obj-triangles.awk).
obj_triangles() {
  local f="$1"
  shift
  awk "$@" -f "$root/scripts/obj-triangles.awk" "$f" | LC_ALL=C sort
}

if [ "$mode" = surface ]; then
  command -v cc >/dev/null || { echo "c-example: no C compiler 'cc' found (apt-get install gcc)" >&2; exit 1; }
  echo "== libtetradrill_ffi.a (profile ffi: release, panic = abort)"
  cargo rustc --quiet -p tetradrill-ffi --profile ffi \
    -- --print native-static-libs 2>"$work/rustc.txt" || { cat "$work/rustc.txt" >&2; exit 1; }
  libs="$(sed -n 's/.*native-static-libs: //p' "$work/rustc.txt" | tail -1)"
  echo "== cc examples/c/surface_demo.c"
  # shellcheck disable=SC2086
  cc -std=c11 -O2 -Wall -Wextra -Werror -ffp-contract=off -I ffi/include \
    examples/c/surface_demo.c "$target_dir/ffi/libtetradrill_ffi.a" $libs -o "$work/surface_demo"
  echo "== run"
  "$work/surface_demo" "$obj" | tee "$work/out.txt"
  bin="${TETRADRILL_BIN:-}"
  if [ -z "$bin" ]; then
    cargo build --release --quiet -p tetradrill
    bin="$target_dir/release/tetradrill"
  fi
  "$bin" replay --scenario builtin:demo --quiet --surface "$work/ref.obj" >/dev/null \
    2>"$work/replay.err" || { cat "$work/replay.err" >&2; exit 1; }
  obj_triangles "$obj" -v normals=1 >"$work/c.txt"
  obj_triangles "$work/ref.obj" -v normals=1 >"$work/ref.txt"
  n="$(wc -l <"$work/c.txt" | tr -d ' ')"
  want="$(wc -l <"$work/ref.txt" | tr -d ' ')"
  if [ "$n" != "$want" ] \
    || ! paste -d '\n' "$work/c.txt" "$work/ref.txt" \
      | awk -f "$root/scripts/obj-normals-diff.awk" >"$work/diff.txt"; then
    echo "c-example: FAIL: surface: $n triangles from C, $want from replay --surface; $(cat "$work/diff.txt" 2>/dev/null)" >&2
    exit 1
  fi
  cat "$work/diff.txt"
  echo "surface: $n triangles, equal to replay --surface (normals too)"
  exit 0
fi

if [ "$mode" = host ]; then
  command -v cc >/dev/null || { echo "c-example: no C compiler 'cc' found (apt-get install gcc)" >&2; exit 1; }
  echo "== libtetradrill_ffi.a and .so (profile ffi: release, panic = abort)"
  # The system libraries the static library needs come from rustc's own list.
  cargo rustc --quiet -p tetradrill-ffi --profile ffi \
    -- --print native-static-libs 2>"$work/rustc.txt" || { cat "$work/rustc.txt" >&2; exit 1; }
  libs="$(sed -n 's/.*native-static-libs: //p' "$work/rustc.txt" | tail -1)"
  lib="$target_dir/ffi/libtetradrill_ffi.a"
  echo "== cc examples/c/replay_demo.c ($libs)"
  # -ffp-contract=off: the block's positions must be the floats the core computes.
  # shellcheck disable=SC2086
  cc -std=c11 -O2 -Wall -Wextra -Werror -ffp-contract=off -I ffi/include \
    examples/c/replay_demo.c "$lib" $libs -o "$work/replay_demo"
  echo "== run"
  "$work/replay_demo" | tee "$work/out.txt"
  compare "$work/out.txt" demo
  echo "== the same program over the shared library (libtetradrill_ffi.so)"
  cc -std=c11 -O2 -Wall -Wextra -Werror -ffp-contract=off -I ffi/include \
    examples/c/replay_demo.c -L "$target_dir/ffi" -ltetradrill_ffi \
    -Wl,-rpath,"$target_dir/ffi" -o "$work/replay_demo_shared"
  "$work/replay_demo_shared" >"$work/out-shared.txt"
  compare "$work/out-shared.txt" demo
  echo "== cc examples/c/soft_demo.c: the cow soft under the burr (a deformable world)"
  # shellcheck disable=SC2086
  cc -std=c11 -O2 -Wall -Wextra -Werror -I ffi/include \
    examples/c/soft_demo.c "$lib" $libs -lm -o "$work/soft_demo"
  "$work/soft_demo" tests/data/meshes/models/spot_tetgen_q1.414.node
  echo "== the same with the step spread over the ticks (td_link_*: a step every 10 ticks)"
  "$work/soft_demo" tests/data/meshes/models/spot_tetgen_q1.414.node --spread 10
  exit 0
fi

if [ "$mode" = tools ]; then
  command -v cc >/dev/null || { echo "c-example: no C compiler 'cc' found (apt-get install gcc)" >&2; exit 1; }
  echo "== libtetradrill_ffi.a (profile ffi)"
  cargo rustc --quiet -p tetradrill-ffi --profile ffi \
    -- --print native-static-libs 2>"$work/rustc.txt" || { cat "$work/rustc.txt" >&2; exit 1; }
  libs="$(sed -n 's/.*native-static-libs: //p' "$work/rustc.txt" | tail -1)"
  lib="$target_dir/ffi/libtetradrill_ffi.a"
  echo "== cc examples/c/drill_demo.c"
  # shellcheck disable=SC2086
  cc -std=c11 -O2 -Wall -Wextra -Werror -ffp-contract=off -I ffi/include \
    examples/c/drill_demo.c "$lib" $libs -lm -o "$work/drill_demo"
  echo "== run"
  "$work/drill_demo" | tee "$work/out.txt"
  compare "$work/out.txt" demo --tool drill:0.1:0.6:0.03
  echo "== cc examples/c/pen_demo.c"
  # shellcheck disable=SC2086
  cc -std=c11 -O2 -Wall -Wextra -Werror -ffp-contract=off -I ffi/include \
    examples/c/pen_demo.c "$lib" $libs -lm -o "$work/pen_demo"
  echo "== run"
  "$work/pen_demo" | tee "$work/out-pen.txt"
  compare "$work/out-pen.txt" demo --tool mesh:builtin:block:2 --tool-scale 0.2
  compare_pen "$work/out-pen.txt"
  exit 0
fi

if [ "$mode" = tsan ]; then
  command -v gcc >/dev/null || { echo "c-example: no C compiler 'gcc' found (apt-get install gcc)" >&2; exit 1; }
  seconds="${TSAN_SECONDS:-10}"
  [[ "$seconds" =~ ^[0-9]+$ ]] && [ "$seconds" -gt 0 ] ||
    { echo "c-example: TSAN_SECONDS takes a whole number of seconds, not '$seconds'" >&2; exit 2; }
  host="$(rustc -vV | sed -n 's/^host: //p')"
  echo "== libtetradrill_ffi.a instrumented for ThreadSanitizer ($host, profile ffi)"
  # The stable compiler's -Zsanitizer=thread (an unstable flag: RUSTC_BOOTSTRAP for this test
  # build only), so TSan sees the Rust side's memory accesses and atomics too; core and std
  # come precompiled without it (hence the mismatch allowance), and the Rust code they inline
  # into the library is instrumented with it.
  RUSTC_BOOTSTRAP=1 RUSTFLAGS="-Zsanitizer=thread -Cunsafe-allow-abi-mismatch=sanitizer" \
    cargo rustc --quiet -p tetradrill-ffi --profile ffi --target "$host" --crate-type staticlib \
    --target-dir "$target_dir/tsan"
  lib="$target_dir/tsan/$host/ffi/libtetradrill_ffi.a"
  # The TSan runtime the Rust instrumentation was made for: rustc's own (Debian gcc 12's
  # libtsan lacks the entry points a newer LLVM calls).
  rt="$(ls "$(rustc --print sysroot)/lib/rustlib/$host/lib/"librustc-*_rt.tsan.a 2>/dev/null | head -1)"
  [ -n "$rt" ] || { echo "c-example: rustc's ThreadSanitizer runtime (librustc-*_rt.tsan.a) not found in its sysroot" >&2; exit 1; }
  echo "== gcc -fsanitize=thread examples/c/two_threads.c"
  gcc -std=c11 -O1 -g -Wall -Wextra -Werror -ffp-contract=off -fsanitize=thread -I ffi/include \
    -c examples/c/two_threads.c -o "$work/two_threads.o"
  gcc "$work/two_threads.o" "$lib" -Wl,--whole-archive "$rt" -Wl,--no-whole-archive \
    -lstdc++ -lgcc_s -lutil -lrt -lpthread -lm -ldl -lc -o "$work/two_threads"
  echo "== run for $seconds s"
  set +e
  TSAN_OPTIONS="halt_on_error=0 exitcode=66" "$work/two_threads" "$seconds" \
    >"$work/out.txt" 2>"$work/err.txt"
  rc=$?
  set -e
  cat "$work/out.txt"
  reports="$(grep -c '^WARNING: ThreadSanitizer' "$work/err.txt" || true)"
  echo "tsan_reports=$reports"
  if [ "$reports" != 0 ]; then
    cat "$work/err.txt" >&2
    echo "c-example: FAIL: ThreadSanitizer reported $reports problems" >&2
    exit 1
  fi
  if [ "$rc" != 0 ]; then
    cat "$work/err.txt" >&2
    echo "c-example: FAIL: the two-thread program exited with status $rc" >&2
    exit 1
  fi
  echo "c-example: OK, two threads for $seconds s, no ThreadSanitizer report"
  exit 0
fi

command -v arm-none-eabi-gcc >/dev/null || { echo "c-example: arm-none-eabi-gcc not found (apt-get install gcc-arm-none-eabi libnewlib-arm-none-eabi)" >&2; exit 1; }
command -v qemu-system-arm >/dev/null || { echo "c-example: qemu-system-arm not found (apt-get install qemu-system-arm)" >&2; exit 1; }
echo "== libtetradrill_ffi.a for thumbv7em-none-eabihf (profile ffi)"
cargo rustc --quiet -p tetradrill-ffi --profile ffi --target thumbv7em-none-eabihf --crate-type staticlib
lib="$target_dir/thumbv7em-none-eabihf/ffi/libtetradrill_ffi.a"
echo "== arm-none-eabi-gcc examples/c/cortex_m, the block from arrays and from a mesh blob"
bin="$(host_bin)"
"$bin" export --quiet --firmware "$work/block4.tdb" --mesh builtin:block:4
make --quiet -C examples/c/cortex_m LIB="$lib" OUT="$work" BLOB="$work/block4.tdb" \
  "$work/replay_firmware.elf" blob soft
# Where a panic could still come from in a linked program (the handler faults, see
# docs/FFI.md): calls from outside `core` into its panic entry points (core::panicking, the
# slice and str index failures, unwrap and expect, RefCell borrows), by the function that
# makes them. More than $panic_max fails the check.
panic_max=0
panic_sites() {
  arm-none-eabi-objdump -d --no-show-raw-insn -C "$1" | awk '
    /^[0-9a-f]+ <.*>:$/ { fn = $0; sub(/^[0-9a-f]+ </, "", fn); sub(/>:$/, "", fn) }
    !/^[0-9a-f]+ </ && fn !~ /^<?core::/ &&
      /<core::(panicking::|slice::index::[a-z_]*fail|str::slice_error_fail|option::(unwrap|expect)_failed|result::unwrap_failed|cell::panic_)/ { n[fn]++; total++ }
    END { print total + 0; for (f in n) printf "  %d %s\n", n[f], f }'
}
# Runs the program $1 under QEMU (the servo period is counted in instructions), output to $2.
run_qemu() {
  set +e
  timeout "${C_EXAMPLE_TIMEOUT:-900}" qemu-system-arm -machine mps2-an386 -cpu cortex-m4 \
    -icount shift=10,align=off,sleep=off -semihosting-config enable=on,target=native \
    -nographic -kernel "$1" </dev/null >"$2" 2>&1
  local rc=$?
  set -e
  cat "$2"
  if [ "$rc" != 0 ]; then
    echo "c-example: FAIL: the firmware exited with status $rc (124 = timeout)" >&2
    exit 1
  fi
  grep -q '^servo=systick' "$2" ||
    { echo "c-example: FAIL: the program did not run its servo in the SysTick interrupt" >&2; exit 1; }
  # The servo's force went through the passivity observer, which never tripped on these
  # healthy paths.
  grep -q '^passivity_trips=0' "$2" ||
    { echo "c-example: FAIL: the passivity observer tripped (or did not run)" >&2; exit 1; }
}
for variant in replay_firmware replay_firmware_blob soft_firmware; do
  elf="$work/$variant.elf"
  arm-none-eabi-size "$elf"
  sites="$(panic_sites "$elf")"
  count="$(echo "$sites" | head -n1)"
  echo "panic call sites in $variant: $count (bound $panic_max)"
  echo "$sites" | tail -n +2
  if [ "$count" -gt "$panic_max" ]; then
    echo "c-example: FAIL: $count panic call sites in $variant, over the bound of $panic_max" >&2
    exit 1
  fi
done
echo "== run under QEMU (mps2-an386, cortex-m4): the block from arrays"
run_qemu "$work/replay_firmware.elf" "$work/out.txt"
compare "$work/out.txt" firmware
echo "== run under QEMU: the block from the blob in flash, its tets read in place"
run_qemu "$work/replay_firmware_blob.elf" "$work/out-blob.txt"
grep -q '^mesh=blob' "$work/out-blob.txt" ||
  { echo "c-example: FAIL: the blob program did not read its mesh from the blob" >&2; exit 1; }
compare "$work/out-blob.txt" firmware
echo "== run under QEMU: the block soft, its step spread over the ticks (td_link_*)"
run_qemu "$work/soft_firmware.elf" "$work/out-soft.txt"
# The same set-up on the host (examples/c/soft_firmware.c over the host's library): the C
# body keeps its tets in an order of its own, so the reference is this program, not the Rust
# firmware's scenario.
command -v cc >/dev/null || { echo "c-example: no C compiler 'cc' found (apt-get install gcc)" >&2; exit 1; }
cargo rustc --quiet -p tetradrill-ffi --profile ffi \
  -- --print native-static-libs 2>"$work/rustc.txt" || { cat "$work/rustc.txt" >&2; exit 1; }
libs="$(sed -n 's/.*native-static-libs: //p' "$work/rustc.txt" | tail -1)"
# shellcheck disable=SC2086
cc -std=c11 -O2 -Wall -Wextra -Werror -ffp-contract=off -I ffi/include \
  examples/c/soft_firmware.c "$target_dir/ffi/libtetradrill_ffi.a" $libs -o "$work/soft_firmware"
"$work/soft_firmware" >"$work/soft-host.txt"
for key in force_digest soft_steps units_per_tick late max_displacement_um; do
  m4="$(sed -n "s/^$key=\([0-9a-f]*\)\r\{0,1\}$/\1/p" "$work/out-soft.txt")"
  host="$(sed -n "s/^$key=\([0-9a-f]*\)$/\1/p" "$work/soft-host.txt")"
  echo "$key: Cortex-M4 $m4, host $host"
  if [ -z "$m4" ] || [ "$m4" != "$host" ]; then
    echo "c-example: FAIL: the soft block's $key differs between the Cortex-M4 and the host" >&2
    exit 1
  fi
done
grep -q '^late=0' "$work/out-soft.txt" ||
  { echo "c-example: FAIL: the link finished a cycle late" >&2; exit 1; }
echo "c-example: OK, the soft block: the same digest and figures on the Cortex-M4 and the host, no deadline missed"
