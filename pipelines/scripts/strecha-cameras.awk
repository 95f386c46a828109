# Strecha et al. ground-truth cameras (`NNNN.jpg.camera`: 3 lines K, 1 line radial distortion,
# 3 lines R camera-to-world, 1 line centre C, 1 line `w h`) to a pg-cameras file (formats/cameras.md):
# ids are the image stems (as pg-track names its frames), cam_from_world = (R^T, -R^T C).
#   awk -v images=/abs/images -v now=2024-01-01T00:00:00Z -f strecha-cameras.awk gt/*.camera > cameras.json
FNR == 1 { n++; line = 0; file[n] = FILENAME }
NF > 0 { line++; for (i = 1; i <= NF; i++) v[n, line, i] = $i }
END {
  printf "{\n\"format\": \"pg-cameras\",\n\"version\": 1,\n"
  printf "\"provenance\": {\"tool\": \"pipelines/scripts/strecha-cameras.awk\", \"version\": \"0.1.0\", "
  printf "\"command_line\": \"awk -f strecha-cameras.awk\", \"created_utc\": \"%s\", \"inputs\": [", now
  for (c = 1; c <= n; c++) printf "%s\"%s\"", (c > 1 ? ", " : ""), file[c]
  printf "]},\n\"cameras\": [\n"
  for (c = 1; c <= n; c++) {
    name = file[c]; sub(/^.*\//, "", name); sub(/\.camera$/, "", name)
    id = name; sub(/\.[^.]*$/, "", id)
    # M = R^T (rows of M are the columns of R): world to camera.
    for (i = 1; i <= 3; i++) for (j = 1; j <= 3; j++) m[i, j] = v[c, 4 + j, i]
    for (i = 1; i <= 3; i++) t[i] = -(m[i, 1] * v[c, 8, 1] + m[i, 2] * v[c, 8, 2] + m[i, 3] * v[c, 8, 3])
    quaternion()
    printf "%s{\"id\": \"%s\", \"image\": \"%s/%s\", \"width\": %d, \"height\": %d, \"model\": \"pinhole\",\n", \
      (c > 1 ? ",\n" : ""), id, images, name, v[c, 9, 1], v[c, 9, 2]
    printf " \"intrinsics\": {\"fx\": %.17g, \"fy\": %.17g, \"cx\": %.17g, \"cy\": %.17g},\n", \
      v[c, 1, 1], v[c, 2, 2], v[c, 1, 3], v[c, 2, 3]
    printf " \"distortion\": {\"k1\": 0, \"k2\": 0, \"k3\": 0, \"k4\": 0, \"k5\": 0, \"k6\": 0, \"p1\": 0, \"p2\": 0},\n"
    printf " \"cam_from_world\": {\"rotation_xyzw\": [%.17g, %.17g, %.17g, %.17g], \"translation\": [%.17g, %.17g, %.17g]}}", \
      qx, qy, qz, qw, t[1], t[2], t[3]
  }
  printf "\n]\n}\n"
}
# Shepperd's method on m: qx qy qz qw.
function quaternion(   tr, s) {
  tr = m[1, 1] + m[2, 2] + m[3, 3]
  if (tr > 0) {
    s = sqrt(tr + 1) * 2; qw = s / 4
    qx = (m[3, 2] - m[2, 3]) / s; qy = (m[1, 3] - m[3, 1]) / s; qz = (m[2, 1] - m[1, 2]) / s
  } else if (m[1, 1] > m[2, 2] && m[1, 1] > m[3, 3]) {
    s = sqrt(1 + m[1, 1] - m[2, 2] - m[3, 3]) * 2; qx = s / 4
    qw = (m[3, 2] - m[2, 3]) / s; qy = (m[1, 2] + m[2, 1]) / s; qz = (m[1, 3] + m[3, 1]) / s
  } else if (m[2, 2] > m[3, 3]) {
    s = sqrt(1 + m[2, 2] - m[1, 1] - m[3, 3]) * 2; qy = s / 4
    qw = (m[1, 3] - m[3, 1]) / s; qx = (m[1, 2] + m[2, 1]) / s; qz = (m[2, 3] + m[3, 2]) / s
  } else {
    s = sqrt(1 + m[3, 3] - m[1, 1] - m[2, 2]) * 2; qz = s / 4
    qw = (m[2, 1] - m[1, 2]) / s; qx = (m[1, 3] + m[3, 1]) / s; qy = (m[2, 3] + m[3, 2]) / s
  }
}
