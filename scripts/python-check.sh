#!/usr/bin/env bash
# The Python package (python/, docs/PYTHON.md) as a user meets it, and as CI runs it:
#
#   scripts/python-check.sh
#
# makes a fresh virtual environment in a temporary folder, installs the package from source
# (`pip install ./python`: maturin builds the extension in release) with pytest, numpy and
# matplotlib, runs `pytest python/tests`, then runs python/examples/drill_tooth.py with
# `--json` and compares its `removed_by_region` with
# `tetradrill replay --scenario builtin:firmware-tooth --json`'s (1e-12 relative, each label).
# Prints one line `python-check: OK ...` at the end, or `python-check: FAILED: ...`.
#
# Exit status: 0 when everything passes; 1 when a step fails; 2 for bad arguments. Needs
# python3 with its venv module and headers (Debian: python3-venv, python3-dev), a C compiler,
# and PyPI. Honours PYTHON (default python3) and TETRADRILL_BIN (default: the release build of
# `tetradrill`, built when missing).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) sed -n '2,17p' "$0"; exit 0 ;;
    *) echo "python-check: unknown argument '$1' (it takes none; see --help)" >&2; exit 2 ;;
  esac
done
start=$(date +%s)
fail() { echo "python-check: FAILED: $*" >&2; exit 1; }
py="${PYTHON:-python3}"
command -v "$py" >/dev/null || fail "no $py (install python3, python3-venv, python3-dev)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
# The tests run from elsewhere: a binary named relative to here, by its absolute path.
case "${TETRADRILL_BIN:-/}" in /*) ;; *) TETRADRILL_BIN="$PWD/$TETRADRILL_BIN" ;; esac
cd "$root"

echo "python-check: a fresh virtual environment ($("$py" --version 2>&1))"
"$py" -m venv "$work/venv" || fail "$py -m venv failed (Debian: apt-get install python3-venv)"
vpy="$work/venv/bin/python"

echo "python-check: pip install ./python pytest numpy matplotlib (maturin builds the extension)"
"$vpy" -m pip install --quiet --disable-pip-version-check ./python pytest numpy matplotlib \
  || fail "pip install ./python failed (see above)"

bin="${TETRADRILL_BIN:-}"
if [ -z "$bin" ]; then
  bin="${CARGO_TARGET_DIR:-$root/target}/release/tetradrill"
  case "$bin" in /*) ;; *) bin="$root/$bin" ;; esac
  if [ ! -x "$bin" ]; then
    echo "python-check: building tetradrill (release) for the replay oracle"
    cargo build --release --quiet -p tetradrill || fail "cargo build -p tetradrill failed"
  fi
fi
[ -x "$bin" ] || fail "no tetradrill binary at $bin"
export TETRADRILL_BIN="$bin"

echo "python-check: pytest python/tests"
set +e
(cd "$work" && "$vpy" -m pytest -q -p no:cacheprovider "$root/python/tests" | tee "$work/pytest.txt")
rc=${PIPESTATUS[0]}
set -e
[ "$rc" = 0 ] || fail "pytest python/tests exited $rc"
passed=$(grep -Eo '[0-9]+ passed' "$work/pytest.txt" | tail -1)
grep -Eq '[0-9]+ skipped' "$work/pytest.txt" && fail "pytest skipped tests: $(tail -1 "$work/pytest.txt")"

echo "python-check: python/examples/drill_tooth.py --json against tetradrill replay --json"
(cd "$work" && "$vpy" "$root/python/examples/drill_tooth.py" --json "$work/example.json" \
  --png "$work/drill_tooth.png") || fail "python/examples/drill_tooth.py failed"
[ -s "$work/drill_tooth.png" ] || fail "the example wrote no plot"
"$bin" replay --scenario builtin:firmware-tooth --json "$work/replay.json" --quiet >/dev/null \
  || fail "tetradrill replay --scenario builtin:firmware-tooth failed"
diff=$("$vpy" - "$work/example.json" "$work/replay.json" <<'PY'
import json, sys
ours = json.load(open(sys.argv[1]))["removed_by_region"]
theirs = json.load(open(sys.argv[2]))["removed_by_region"]
if sorted(ours) != sorted(theirs):
    sys.exit(f"labels differ: example {sorted(ours)}, replay {sorted(theirs)}")
worst = 0.0
for k, v in theirs.items():
    rel = abs(ours[k] - v) / max(abs(v), abs(ours[k]), 1e-300)
    if rel > 1e-12:
        sys.exit(f"region {k}: example {ours[k]!r}, replay {v!r} (relative {rel:.3e})")
    worst = max(worst, rel)
print(f"{len(theirs)} regions, largest relative difference {worst:.1e}")
PY
) || fail "removed_by_region: $diff"

echo "python-check: OK: $passed, drill_tooth.py's removed_by_region equals replay's ($diff), $(( $(date +%s) - start )) s"
