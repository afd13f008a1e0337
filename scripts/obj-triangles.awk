# The triangles of an OBJ file (`v x y z` and `f a b c` or `f a//na b//nb c//nc` lines,
# 1-based), one line each, every coordinate snapped to the nearest float and printed with 9
# digits (two decimal writings of the same float give the same line), each triangle's vertices
# rotated to start at the least one (the orientation kept). With `-v normals=1`, the corners'
# normals (`vn`, snapped the same way, in the same order; `-` where the face gives none) follow
# after ` || `, so the lines still sort by the corners. Sort the output to compare two files as
# sets of triangles (scripts/obj-normals-diff.awk compares the normals within a tolerance):
#
#   awk -f scripts/obj-triangles.awk [-v normals=1] FILE.obj | LC_ALL=C sort
function snap(x,   s, a, u, q, r) {
  if (x == 0) return 0
  s = 1; a = x
  if (a < 0) { s = -1; a = -a }
  u = 1
  while (a >= 2 * u) u *= 2
  while (a < u) u /= 2
  u /= 8388608
  q = a / u; r = int(q)
  if (q - r >= 0.5) r++
  return s * r * u
}
$1 == "v" { n++; v[n] = sprintf("%.9g %.9g %.9g", snap($2 + 0), snap($3 + 0), snap($4 + 0)) }
$1 == "vn" { m++; vn[m] = sprintf("%.9g %.9g %.9g", snap($2 + 0), snap($3 + 0), snap($4 + 0)) }
$1 == "f" {
  for (k = 1; k <= 3; k++) {
    split($(k + 1), p, "/")
    c[k] = v[p[1] + 0]
    nn[k] = ""
    if (normals) nn[k] = ((3 in p) && p[3] != "" ? vn[p[3] + 0] : "-")
  }
  s = 1
  if (c[2] < c[s]) s = 2
  if (c[3] < c[s]) s = 3
  t = s % 3 + 1; u = t % 3 + 1
  line = c[s] " | " c[t] " | " c[u]
  if (normals) line = line " || " nn[s] " | " nn[t] " | " nn[u]
  print line
}
