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
check_below "camera rotation error max (deg)" "$(metric "$c" rotation_error_deg_max)" 0.5
[ -s "$work/remesh/remeshed.ply" ] || fail "no final mesh"
cat "$work/shot-report.md"
