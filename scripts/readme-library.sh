#!/usr/bin/env bash
# Keeps README's "Use it as a library" true: makes a new crate with `cargo new` outside the
# checkout, beside a `tetradrill` folder that is this checkout (the layout the README's
# dependency line assumes), pastes the README's program into its main.rs, runs it, and checks
# that it prints the removed volume of the tooth's three regions and the drilled surface's
# triangle count, in at most 30 lines of code.
#
# Usage: scripts/readme-library.sh   (CARGO_TARGET_DIR is shared when set)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
ln -s "$root" "$work/tetradrill"
(cd "$work" && cargo new --quiet --bin readme_user)
# The dependency line and the program: the first ```toml and ```rust blocks of the section.
section="$(awk '/^## Use it as a library/{on=1; next} /^## /{on=0} on' "$root/README.md")"
deps="$(printf '%s\n' "$section" | awk '/^```toml/{on=1; next} /^```/{if(on) exit} on' | grep -v '^\[dependencies\]')"
program="$(printf '%s\n' "$section" | awk '/^```rust/{on=1; next} /^```/{if(on) exit} on')"
[ -n "$deps" ] && [ -n "$program" ] || { echo "readme-library: no toml or rust block in the section" >&2; exit 1; }
lines=$(printf '%s\n' "$program" | grep -c -v '^\s*$' || true)
echo "readme-library: the program is $lines lines (blank lines not counted)"
[ "$lines" -le 30 ] || { echo "readme-library: more than 30 lines" >&2; exit 1; }
printf '%s\n' "$deps" >> "$work/readme_user/Cargo.toml"
printf '%s\n' "$program" > "$work/readme_user/src/main.rs"
out="$(cd "$work/readme_user" && cargo run --quiet --release 2>&1)" || { printf '%s\n' "$out" >&2; exit 1; }
printf '%s\n' "$out"
for label in 1 2 3; do
  printf '%s\n' "$out" | grep -Eq "^region $label: [0-9.]+ mm\^3 removed" \
    || { echo "readme-library: no removed volume for region $label" >&2; exit 1; }
done
printf '%s\n' "$out" | grep -Eq '^drilled surface: [1-9][0-9]* triangles' \
  || { echo "readme-library: no triangle count" >&2; exit 1; }
echo "readme-library: OK"
