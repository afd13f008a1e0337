#!/usr/bin/env bash
# Fuzzes every parser and frame decoder (docs/FUZZING.md), one target at a time, one job each.
# Not part of CI.
#
#   scripts/fuzz.sh [SECONDS_PER_TARGET] [TARGET...]     (default 60 s, all targets)
#
# Needs cargo-fuzz (`cargo install cargo-fuzz`). This machine has only stable Rust, so the
# script sets RUSTC_BOOTSTRAP=1 for the -Z flags cargo-fuzz passes. FUZZ_SANITIZER=none turns
# AddressSanitizer off (it is on by default; the stable toolchain ships its runtime).
#
# Seeds: fuzz/seeds/<target>/ (small hand-written files, committed) plus, for the mesh targets,
# the real files in $TETRADRILL_MESHES (default tests/data/meshes), copied at run time into
# fuzz/corpus/<target>/, which is ignored by git and grows from run to run. Before fuzzing, each
# mesh target runs once over the whole real files (larger than -max_len).
#
# Prints one line per target: PASS or FAIL, seconds, runs, coverage, corpus size; a FAIL names
# the crashing input in fuzz/artifacts/<target>/ and the log in fuzz/logs/<target>.log. The exit
# status is 1 when any target failed.

set -uo pipefail

secs=${1:-60}
shift || true
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
fuzz="$root/fuzz"
meshes=${TETRADRILL_MESHES:-$root/tests/data/meshes}
sanitizer=${FUZZ_SANITIZER:-address}
all=(mesh_tetgen mesh_medit mesh_meshb mesh_gmsh mesh_vtk mesh_vtu mesh_gz mesh_blob trace scenario falcon omni)
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=("${all[@]}")

case $secs in
    '' | *[!0-9]*) echo "fuzz.sh: SECONDS_PER_TARGET must be a whole number, not '$secs'" >&2; exit 2 ;;
esac
if ! cargo fuzz --version > /dev/null 2>&1; then
    echo "fuzz.sh: cargo-fuzz is missing: cargo install cargo-fuzz" >&2
    exit 2
fi

export RUSTC_BOOTSTRAP=1
# The readers take paths: each input is written to a scratch file, in memory where possible
# (on a disk-backed /tmp a write costs milliseconds and slows the mesh targets 15-fold).
tmp=${TMPDIR:-/tmp}
[ -d /dev/shm ] && [ -w /dev/shm ] && tmp=/dev/shm
scratch=$(mktemp -d "$tmp/tetradrill-fuzz.XXXXXX")
trap 'rm -rf "$scratch"' EXIT
export TETRADRILL_FUZZ_SCRATCH="$scratch"
flags=(--fuzz-dir "$fuzz" -O -a --sanitizer "$sanitizer")

echo "fuzz.sh: building the targets (sanitizer $sanitizer)"
if ! cargo fuzz build "${flags[@]}" > "$scratch/build.log" 2>&1; then
    cat "$scratch/build.log" >&2
    echo "fuzz.sh: build failed" >&2
    exit 1
fi
bin="$fuzz/target/x86_64-unknown-linux-gnu/release"

# The real mesh files that seed each mesh target (none for the other targets).
real_seeds() {
    local m=$meshes
    [ -d "$m" ] || return 0
    case $1 in
        mesh_medit) ls "$m"/cube12/*.mesh "$m"/formats/*.mesh "$m"/models/pen_tool_gmsh.mesh ;;
        mesh_meshb) ls "$m"/formats/binary/*.meshb ;;
        mesh_gmsh) ls "$m"/cube12/*.msh "$m"/formats/*.msh "$m"/formats/binary/*.msh \
            "$m"/models/pen_tool_gmsh.msh22.msh ;;
        mesh_vtk) ls "$m"/cube12/*.vtk "$m"/models/*.vtk "$m"/formats/binary/*.vtk ;;
        mesh_vtu) ls "$m"/cube12/*.vtu "$m"/models/*.vtu "$m"/formats/binary/*.vtu ;;
    esac 2> /dev/null
}

# TetGen pairs become one input: the .node file, a NUL byte, the .ele file.
tetgen_seeds() {
    local m=$meshes out=$1
    [ -d "$m" ] || return 0
    for node in "$m"/cube12/*.node "$m"/formats/*.node "$m"/models/spot_tetgen_coarse.node; do
        [ -f "$node" ] || continue
        local ele=${node%.node}.ele name
        name=$(basename "${node%.node}")
        { cat "$node"; printf '\0'; cat "$ele"; } > "$out/real_$name"
    done
}

failed=0
for t in "${targets[@]}"; do
    if [ ! -x "$bin/$t" ]; then
        echo "FAIL $t: no such target (targets: ${all[*]})"
        failed=1
        continue
    fi
    corpus="$fuzz/corpus/$t"
    mkdir -p "$corpus" "$fuzz/artifacts/$t" "$fuzz/logs"
    [ -d "$fuzz/seeds/$t" ] && cp -n "$fuzz/seeds/$t"/* "$corpus"/ 2> /dev/null
    log="$fuzz/logs/$t.log"
    : > "$log"
    if [ "$t" = mesh_tetgen ]; then
        full="$scratch/full_$t"
        mkdir -p "$full"
        tetgen_seeds "$full"
        cp -n "$full"/* "$corpus"/ 2> /dev/null
        mapfile -t real < <(ls "$full"/* 2> /dev/null)
    else
        mapfile -t real < <(real_seeds "$t")
        for f in "${real[@]}"; do cp -n "$f" "$corpus/real_$(basename "$f")"; done
    fi
    # Whole real files once (the fuzzing below truncates inputs to -max_len).
    if [ ${#real[@]} -gt 0 ] && ! "$bin/$t" "${real[@]}" >> "$log" 2>&1; then
        echo "FAIL $t: a real mesh file fails (see $log)"
        failed=1
        continue
    fi
    max_len=4096
    case $t in mesh_*) max_len=65536 ;; esac
    dict=()
    [ -f "$fuzz/dicts/$t.dict" ] && dict=("-dict=$fuzz/dicts/$t.dict")
    start=$(date +%s)
    "$bin/$t" "$corpus" -artifact_prefix="$fuzz/artifacts/$t/" -max_total_time="$secs" \
        -max_len="$max_len" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
        "${dict[@]}" >> "$log" 2>&1
    rc=$?
    took=$(($(date +%s) - start))
    runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | tail -1 | grep -o '[0-9]*$')
    cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | grep -o '[0-9]*$')
    n=$(ls "$corpus" | wc -l)
    if [ $rc -eq 0 ]; then
        echo "PASS $t: ${took}s, ${runs:-?} runs, cov ${cov:-?}, corpus $n"
    else
        art=$(grep -o "Test unit written to [^ ]*" "$log" | tail -1 | sed 's/Test unit written to //')
        echo "FAIL $t: exit $rc after ${took}s, input ${art:-?} (see $log)"
        failed=1
    fi
done
exit $failed
