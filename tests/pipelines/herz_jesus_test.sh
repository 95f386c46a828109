#!/bin/sh
# Scenario 2 on Strecha Herz-Jesus-P8 (pipelines/herz-jesus.mk): camera error against the published
# cameras. Long: runs only with PG_LONG_TESTS=1 and the data in $PG_DATA_DIR (default ../shared/data).
# Usage: herz_jesus_test.sh TOOLS_DIR WORK_DIR   (from the repository root)
. "$(dirname "$0")/lib.sh"
bin="$1"; work="$2"
data="${PG_DATA_DIR:-../shared/data}"
if [ "${PG_LONG_TESTS:-}" != 1 ]; then echo "SKIP: set PG_LONG_TESTS=1 to run scenario 2 on Herz-Jesus-P8"; exit 77; fi
if [ ! -d "$data/multiview/strecha/Herz-Jesus-P8/images" ]; then
  echo "SKIP: $data/multiview/strecha/Herz-Jesus-P8 is absent (set PG_DATA_DIR)"; exit 77
fi
rm -rf "$work"
make -f pipelines/herz-jesus.mk WORK="$work" PG_BIN="$bin" PG_DATA_DIR="$data" PROGRESS=off -j2 \
  || fail "make -j2 failed"
# The scene is about 10 m deep; Strecha's cameras are metric.
c="$work/reports/eval-cameras.report.json"
check_below "camera centre error RMS (m)" "$(metric "$c" centre_error_rms)" 0.05
# Each camera's own orientation (orientation_error_deg); the rotation after the centre similarity also
# carries that similarity's tilt about the nearly straight camera path (about 0.5 degrees here).
check_below "camera orientation error max (deg)" "$(metric "$c" orientation_error_deg_max)" 0.25
check_below "camera rotation error after the centre similarity, max (deg)" "$(metric "$c" rotation_error_deg_max)" 1.0
# The mesh's photometric consistency: photos projected through it agree better after refinement.
rf="$work/reports/refine.report.json"
check_below "refined 1-NCC" "$(metric "$rf" ncc_error_after)" "$(metric "$rf" ncc_error_before)"
grep -q "ncc_error_after" "$work/shot-report.md" || fail "the shot report lacks the photometric consistency"
[ -s "$work/remesh/remeshed.ply" ] || fail "no final mesh"
cat "$work/shot-report.md"
