# Moves a cameras file (pg-cameras) into another world frame by the similarity that `pg-eval cameras`
# found (its result.alignment maps estimate world points into the truth world: X' = s R X + t).
# Each camera keeps its projection: rotation q' = q * conj(q_align), translation t' = s t - R' t_align,
# so depths come out in the truth's units. Plain awk (mawk/gawk), no JSON library needed.
#
#   awk -f align-cameras.awk EVAL.json CAMERAS.json > aligned.json.tmp && mv aligned.json.tmp aligned.json
#
# Keep the output beside CAMERAS.json: image paths are relative to the file's folder.
BEGIN { RS = "\034" }

FNR == 1 && NR == 1 { eval_text = $0; next }
{ cameras_text = cameras_text $0 }

END {
  if (!match(eval_text, /"alignment"[^}]*}/)) fail("no alignment in the pg-eval cameras result")
  alignment = substr(eval_text, RSTART, RLENGTH)
  s = number_after(alignment, "scale")
  if (array_after(alignment, "rotation_wxyz", qa) != 4) fail("alignment rotation_wxyz is not 4 numbers")
  if (array_after(alignment, "translation", ta) != 3) fail("alignment translation is not 3 numbers")
  text = cameras_text
  sub(/"tool": *"[^"]*"/, "\"tool\": \"pipelines/scripts/align-cameras.awk\"", text)
  out = ""
  while (match(text, /"rotation_xyzw"[ \t\r\n]*:[ \t\r\n]*\[[^\]]*\]/)) {
    out = out substr(text, 1, RSTART - 1)
    n = split(numbers_of(substr(text, RSTART, RLENGTH)), q, " ")
    text = substr(text, RSTART + RLENGTH)
    if (n != 4) fail("a rotation_xyzw is not 4 numbers")
    if (!match(text, /"translation"[ \t\r\n]*:[ \t\r\n]*\[[^\]]*\]/)) fail("a camera has no translation")
    between = substr(text, 1, RSTART - 1)
    n = split(numbers_of(substr(text, RSTART, RLENGTH)), t, " ")
    text = substr(text, RSTART + RLENGTH)
    if (n != 3) fail("a translation is not 3 numbers")
    # q (x y z w) times the conjugate of the alignment (w x y z): Hamilton product.
    aw = qa[1]; ax = -qa[2]; ay = -qa[3]; az = -qa[4]
    bx = q[1]; by = q[2]; bz = q[3]; bw = q[4]
    w = bw * aw - bx * ax - by * ay - bz * az
    x = bw * ax + bx * aw + by * az - bz * ay
    y = bw * ay - bx * az + by * aw + bz * ax
    z = bw * az + bx * ay - by * ax + bz * aw
    norm = sqrt(w * w + x * x + y * y + z * z)
    w /= norm; x /= norm; y /= norm; z /= norm
    r11 = 1 - 2 * (y * y + z * z); r12 = 2 * (x * y - z * w); r13 = 2 * (x * z + y * w)
    r21 = 2 * (x * y + z * w); r22 = 1 - 2 * (x * x + z * z); r23 = 2 * (y * z - x * w)
    r31 = 2 * (x * z - y * w); r32 = 2 * (y * z + x * w); r33 = 1 - 2 * (x * x + y * y)
    t1 = s * t[1] - (r11 * ta[1] + r12 * ta[2] + r13 * ta[3])
    t2 = s * t[2] - (r21 * ta[1] + r22 * ta[2] + r23 * ta[3])
    t3 = s * t[3] - (r31 * ta[1] + r32 * ta[2] + r33 * ta[3])
    out = out sprintf("\"rotation_xyzw\": [%.17g, %.17g, %.17g, %.17g]", x, y, z, w) between
    out = out sprintf("\"translation\": [%.17g, %.17g, %.17g]", t1, t2, t3)
  }
  printf "%s", out text
}

function fail(message) { print "align-cameras: " message > "/dev/stderr"; exit 3 }

function numbers_of(array_text) {
  sub(/^[^\[]*\[/, "", array_text)
  sub(/\].*$/, "", array_text)
  gsub(/[, \t\r\n]+/, " ", array_text)
  sub(/^ /, "", array_text)
  return array_text
}

function array_after(text, key, result) {
  if (!match(text, "\"" key "\"[ \t\r\n]*:[ \t\r\n]*\\[[^\\]]*\\]")) return 0
  return split(numbers_of(substr(text, RSTART, RLENGTH)), result, " ")
}

function number_after(text, key) {
  if (!match(text, "\"" key "\"[ \t\r\n]*:[ \t\r\n]*[-+0-9.eE]+")) fail("no " key " in the alignment")
  text = substr(text, RSTART, RLENGTH)
  sub(/^[^:]*:[ \t\r\n]*/, "", text)
  return text + 0
}
