#!/usr/bin/env bash
# Instructions per call of one function, under callgrind: the mean, p99 and max over every
# call, and the calls that cost most. A steady figure where wall-clock percentiles are not
# (a loaded or virtual machine): docs/DRILLING.md gives the shaft's tracking per step so.
#
#   scripts/per-call.sh COLLECT DUMP -- COMMAND [ARGS...]
#
# COLLECT and DUMP are callgrind function patterns (`--toggle-collect`, `--dump-after`) for
# the same function written differently, e.g. '*track_shaft*' '*World*track_shaft*' (with
# one string for both, or some other pairs, valgrind 3.19 dumps or collects nothing: check
# that the totals are not zero); COMMAND runs under valgrind, e.g. a release
# `tetradrill replay`.
# Dumps go to a temporary folder, removed at the end (about 18 KB a call).
set -euo pipefail

usage() {
    echo "usage: scripts/per-call.sh COLLECT DUMP -- COMMAND [ARGS...]" >&2
    exit 2
}

[ $# -ge 4 ] && [ "$3" = "--" ] || usage
collect=$1
dump=$2
shift 3
command -v valgrind >/dev/null || { echo "per-call.sh: valgrind not found (apt-get install valgrind)" >&2; exit 2; }
command -v python3 >/dev/null || { echo "per-call.sh: python3 not found" >&2; exit 2; }

dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT

echo "per-call.sh: running $1 under callgrind, collecting in $collect, a dump after each call of $dump" >&2
valgrind --tool=callgrind --collect-atstart=no --toggle-collect="$collect" \
    --dump-after="$dump" --callgrind-out-file="$dir/cg" "$@" >/dev/null 2>"$dir/err" || {
    echo "per-call.sh: the command failed under valgrind; its last lines:" >&2
    tail -5 "$dir/err" >&2
    exit 2
}

python3 - "$dir" "$dump" <<'EOF'
import glob, math, os, re, sys

folder, dump = sys.argv[1], sys.argv[2]
calls = []
for path in glob.glob(os.path.join(folder, "cg.*")):
    m = re.search(r"\.(\d+)$", path)
    if not m:
        continue
    with open(path) as f:
        for line in f:
            if line.startswith(("totals:", "summary:")):
                calls.append((int(m.group(1)), int(line.split()[1])))
                break
if not calls:
    print(f"per-call.sh: no dump after {dump}: no call, or valgrind ignored the pattern", file=sys.stderr)
    sys.exit(2)
calls.sort()
counts = sorted(n for _, n in calls)
p99 = counts[min(len(counts) - 1, math.ceil(0.99 * len(counts)) - 1)]
total = sum(counts)
if total == 0:
    print("per-call.sh: every call counted zero: valgrind ignored the collect pattern", file=sys.stderr)
    sys.exit(2)
print(f"calls {len(counts)}  total {total:,}  mean {total // len(counts):,}  "
      f"p99 {p99:,}  max {counts[-1]:,} instructions")
worst = sorted(calls, key=lambda c: c[1], reverse=True)[:10]
print("costliest calls (numbered from 1):", ", ".join(f"{i} ({n:,})" for i, n in worst))
EOF
