# Compares two sorted outputs of `scripts/obj-triangles.awk -v normals=1` line by line: the
# corners must be the same text, each normal's components within `tol` (default 1e-5; the
# normals of an incremental update and of one from scratch agree to about 1e-7). Reads the
# pairs as `paste -d '\n' A B` gives them; prints `triangles=N differing_corners=C
# max_normal_difference=D` and exits 1 when any corners or normal differ.
#
#   paste -d '\n' A.txt B.txt | awk [-v tol=1e-5] -f scripts/obj-normals-diff.awk
BEGIN { if (tol == "") tol = 1e-5 }
NR % 2 == 1 { a = $0; next }
{
  n++
  split(a, x, / \|\| /); split($0, y, / \|\| /)
  if (x[1] != y[1]) { corners++; next }
  k = split(x[2], u, /[ |]+/); split(y[2], v, /[ |]+/)
  for (i = 1; i <= k; i++) {
    if (u[i] == "-" || v[i] == "-") { if (u[i] != v[i]) bad++; continue }
    d = u[i] - v[i]; if (d < 0) d = -d
    if (d > max) max = d
    if (d > tol) bad++
  }
}
END {
  printf "triangles=%d differing_corners=%d max_normal_difference=%.3g\n", n, corners + 0, max + 0
  exit (corners + bad > 0) ? 1 : 0
}
