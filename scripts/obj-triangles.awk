# The triangles of an OBJ file (`v x y z` and `f a b c` lines, 1-based), one line each, every
# coordinate snapped to the nearest float and printed with 9 digits (two decimal writings of
# the same float give the same line), each triangle's vertices rotated to start at the least
# one (the orientation kept). Sort the output to compare two files as sets of triangles:
#
#   awk -f scripts/obj-triangles.awk FILE.obj | LC_ALL=C sort
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
$1 == "f" {
  a = v[$2 + 0]; b = v[$3 + 0]; c = v[$4 + 0]
  if (b < a && b <= c) { t = a; a = b; b = c; c = t }
  else if (c < a && c < b) { t = c; c = b; b = a; a = t }
  print a " | " b " | " c
}
