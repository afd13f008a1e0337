#!/usr/bin/env bash
# Regenerates the real-size premolar from its Gmsh model: tests/data/meshes/models/premolar.geo
# (a maxillary second premolar, 22.5 mm long, with enamel, dentin and pulp; millimetres in the
# model, metres in the mesh) meshed in 3D and written as Gmsh 2.2 ASCII, the physical volumes
# as the region labels (1 enamel, 2 dentin, 3 pulp), to
# tests/data/meshes/models/premolar_gmsh.msh22.msh.
#
#   scripts/make-premolar.sh [OUT]
#
# Needs the `gmsh` binary (`pip install gmsh` gives it; the committed mesh was made with Gmsh
# 4.15.2 on one thread, and another version may place the nodes differently). Takes about five
# minutes of one core (the lofted surfaces). Prints the tet count by label. The firmware's
# small tooth is scripts/make-tooth.sh's.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
models="$root/tests/data/meshes/models"
out="${1:-$models/premolar_gmsh.msh22.msh}"
command -v gmsh >/dev/null || { echo "make-premolar: gmsh not found (pip install gmsh)" >&2; exit 1; }
gmsh "$models/premolar.geo" -3 -nt 1 -format msh22 -o "$out" >/dev/null
echo "make-premolar: $out (Gmsh $(gmsh --version 2>&1 | tail -n1))"
# Tets (element type 4) by physical tag, the first tag after the tag count.
awk '/^\$Elements/ { on = 1; getline; next } /^\$EndElements/ { on = 0 }
     on && $2 == 4 { n[$4]++ } END { for (l in n) printf "label %s: %d tets\n", l, n[l] }' "$out" | sort
