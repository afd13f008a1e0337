# The smoothness of an OBJ's `drilled` group (`v`, `vn`, `g`, `f a//na b//nb c//nc` lines):
# each vertex's normal is the unit mean of the normals of its corners in the group; prints
# the mean angle in degrees between the normals of the two ends of every edge of the group,
# and the share of the group's corners whose normal is their triangle's own (flat). With
# -v max_deg=D -v max_flat=F it exits 1 when the mean is not below D or the share not below F.
#
#   awk -v max_deg=10 -v max_flat=0.02 -f scripts/obj-smoothness.awk FILE.obj
function acos(x) { if (x > 1) x = 1; if (x < -1) x = -1; return atan2(sqrt(1 - x * x), x) }
$1 == "v" { nv++; px[nv] = $2 + 0; py[nv] = $3 + 0; pz[nv] = $4 + 0 }
$1 == "vn" { nn++; nx[nn] = $2 + 0; ny[nn] = $3 + 0; nz[nn] = $4 + 0 }
$1 == "g" { group = $2 }
$1 == "f" && group == "drilled" {
  for (k = 1; k <= 3; k++) { split($(k + 1), p, "//"); v[k] = p[1] + 0; n[k] = p[2] + 0 }
  ux = px[v[2]] - px[v[1]]; uy = py[v[2]] - py[v[1]]; uz = pz[v[2]] - pz[v[1]]
  wx = px[v[3]] - px[v[1]]; wy = py[v[3]] - py[v[1]]; wz = pz[v[3]] - pz[v[1]]
  cx = uy * wz - uz * wy; cy = uz * wx - ux * wz; cz = ux * wy - uy * wx
  l = sqrt(cx * cx + cy * cy + cz * cz); if (l > 0) { cx /= l; cy /= l; cz /= l }
  for (k = 1; k <= 3; k++) {
    sx[v[k]] += nx[n[k]]; sy[v[k]] += ny[n[k]]; sz[v[k]] += nz[n[k]]; corners++
    dx = nx[n[k]] - cx; dy = ny[n[k]] - cy; dz = nz[n[k]] - cz
    if (dx * dx + dy * dy + dz * dz < 1e-8) flat++
    a = v[k]; b = v[k % 3 + 1]; if (a > b) { t = a; a = b; b = t }
    edge[a " " b] = 1
  }
  faces++
}
END {
  if (faces == 0) { print "obj-smoothness: no face in group drilled" > "/dev/stderr"; exit 1 }
  for (e in edge) {
    split(e, ab, " "); a = ab[1]; b = ab[2]
    la = sqrt(sx[a] * sx[a] + sy[a] * sy[a] + sz[a] * sz[a])
    lb = sqrt(sx[b] * sx[b] + sy[b] * sy[b] + sz[b] * sz[b])
    d = (sx[a] * sx[b] + sy[a] * sy[b] + sz[a] * sz[b]) / (la * lb)
    sum += acos(d) * 180 / 3.141592653589793; edges++
  }
  mean = sum / edges; share = flat / corners
  printf "drilled: %d faces, %d edges, mean neighbour angle %.2f degrees, %.2f %% flat corners\n", faces, edges, mean, 100 * share
  if (max_deg != "" && mean >= max_deg + 0) { print "obj-smoothness: FAIL: mean angle not below " max_deg > "/dev/stderr"; exit 1 }
  if (max_flat != "" && share >= max_flat + 0) { print "obj-smoothness: FAIL: flat share not below " max_flat > "/dev/stderr"; exit 1 }
}
