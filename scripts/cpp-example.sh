#!/usr/bin/env bash
# The C++ example over the header-only wrapper (ffi/include/tetradrill.hpp, docs/FFI.md):
# builds examples/cpp with CMake as a simulator's project would (examples/cpp/CMakeLists.txt:
# add_subdirectory of ffi/, whose target tetradrill::tetradrill runs cargo for
# libtetradrill_ffi.a; C++20, -Wall -Wextra -Wpedantic -Werror), drills the premolar's
# access cavity from its mesh file, writes its drilled surface (kept in an engine's buffers frame by frame) to
# OUT.obj, and compares its force digest and removed_by_region with
# `tetradrill replay --scenario builtin:firmware-tooth --json`'s and the surface with
# `--surface`'s (the same triangles, any order, and their smooth normals within 1e-5); before
# that, builds and runs examples/cpp/checks.cpp (errors as exceptions, a moved world, the
# servo on a thread, a soft body).
#
#   scripts/cpp-example.sh OUT.obj
#
# Exit status: 0 when they match; 1 when they differ or a build or run fails; 2 for bad
# arguments. Honours CARGO_TARGET_DIR (default: the workspace's target/), TETRADRILL_BIN
# (default: the release build of `tetradrill`, built when missing) and TETRADRILL_MESHES (where
# the tooth's mesh is looked for first, as the scenario does).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
obj=""
while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) sed -n '2,18p' "$0"; exit 0 ;;
    -*) echo "cpp-example: unknown argument '$1' (expected OUT.obj)" >&2; exit 2 ;;
    *) [ -z "$obj" ] || { echo "cpp-example: one OUT.obj only, not also '$1'" >&2; exit 2; }
       obj="$1"; shift ;;
  esac
done
[ -n "$obj" ] || { echo "cpp-example: usage: scripts/cpp-example.sh OUT.obj" >&2; exit 2; }
case "$obj" in /*) ;; *) obj="$PWD/$obj" ;; esac
target_dir="${CARGO_TARGET_DIR:-$root/target}"
case "$target_dir" in /*) ;; *) target_dir="$root/$target_dir" ;; esac
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
cd "$root"
command -v g++ >/dev/null || { echo "cpp-example: no C++ compiler 'g++' found (apt-get install g++)" >&2; exit 1; }
command -v cmake >/dev/null || { echo "cpp-example: no 'cmake' found (apt-get install cmake)" >&2; exit 1; }

bin="${TETRADRILL_BIN:-}"
if [ -z "$bin" ]; then
  cargo build --release --quiet -p tetradrill
  bin="$target_dir/release/tetradrill"
fi
mesh="tests/data/meshes/models/tooth_premolar_gmsh.msh22.msh"
if [ -n "${TETRADRILL_MESHES:-}" ] && [ -f "$TETRADRILL_MESHES/models/tooth_premolar_gmsh.msh22.msh" ]; then
  mesh="$TETRADRILL_MESHES/models/tooth_premolar_gmsh.msh22.msh"
fi

echo "== cmake: examples/cpp/CMakeLists.txt over ffi/ (add_subdirectory, tetradrill::tetradrill)"
cmake -S examples/cpp -B "$work/build" -DCMAKE_BUILD_TYPE=Release \
  -DTETRADRILL_CARGO_TARGET_DIR="$target_dir" >"$work/cmake.log" 2>&1 \
  && cmake --build "$work/build" >>"$work/cmake.log" 2>&1 \
  || { cat "$work/cmake.log" >&2; echo "cpp-example: FAIL: the CMake build" >&2; exit 1; }
cp "$work/build/checks" "$work/build/drill_tooth" "$work/"
mkdir -p "$work/scratch"
"$work/checks" "$work/scratch" || { echo "cpp-example: FAIL: the wrapper's checks" >&2; exit 1; }
echo "== run on $mesh"
"$work/drill_tooth" "$mesh" "$obj" | tee "$work/out.txt"

"$bin" replay --scenario builtin:firmware-tooth --quiet --json "$work/replay.json" \
  --surface "$work/ref.obj" >/dev/null \
  2>"$work/replay.err" || { cat "$work/replay.err" >&2; exit 1; }
want="$(sed -n 's/.*"force_digest": *"\([0-9a-f]\{16\}\)".*/\1/p' "$work/replay.json" | head -1)"
got="$(sed -n 's/^force_digest=\([0-9a-f]\{16\}\)$/\1/p' "$work/out.txt")"
echo "C++ wrapper:  force_digest=$got"
echo "host replay:  force_digest=$want (replay --scenario builtin:firmware-tooth)"
[ -n "$got" ] && [ "$got" = "$want" ] || { echo "cpp-example: FAIL: the digests differ" >&2; exit 1; }
cpp_regions="$(sed -n '/^removed_by_region\./p' "$work/out.txt")"
host_regions="$(sed -n '/"removed_by_region": *{/,/}/p' "$work/replay.json" |
  sed -n 's/^ *"\(-\{0,1\}[0-9]*\)": *\([-0-9.eE+]*\),\{0,1\}$/\1 \2/p' |
  awk '{ printf "removed_by_region.%s=%.6e\n", $1, $2 }')"
if [ "$cpp_regions" != "$host_regions" ]; then
  printf 'cpp-example: FAIL: removed_by_region differs; C++:\n%s\nhost:\n%s\n' "$cpp_regions" "$host_regions" >&2
  exit 1
fi
echo "cpp-example: OK, the same digest and removed_by_region ($(echo "$cpp_regions" | paste -sd' '))"
awk -v normals=1 -f scripts/obj-triangles.awk "$obj" | LC_ALL=C sort >"$work/cpp.txt"
awk -v normals=1 -f scripts/obj-triangles.awk "$work/ref.obj" | LC_ALL=C sort >"$work/ref.txt"
n="$(wc -l <"$work/cpp.txt" | tr -d ' ')"
want="$(wc -l <"$work/ref.txt" | tr -d ' ')"
if [ "$n" = 0 ] || [ "$n" != "$want" ] \
  || ! paste -d '\n' "$work/cpp.txt" "$work/ref.txt" \
    | awk -f scripts/obj-normals-diff.awk >"$work/diff.txt"; then
  echo "cpp-example: FAIL: surface: $n triangles from C++, $want from replay --surface; $(cat "$work/diff.txt" 2>/dev/null)" >&2
  exit 1
fi
cat "$work/diff.txt"
echo "surface: $n triangles, equal to replay --surface (normals too)"
