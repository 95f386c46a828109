#!/bin/sh
# Scenario 3 (pipelines/synth-scenario3.mk): the room's panorama pair through pg-sphdepth, merged
# with a range scan, then refined; the meshes are measured against the room's true mesh.
# Usage: scenario3_test.sh TOOLS_DIR WORK_DIR   (from the repository root)
. "$(dirname "$0")/lib.sh"
bin="$1"; work="$2"
rm -rf "$work"
make -f pipelines/synth-scenario3.mk WORK="$work" PG_BIN="$bin" PROGRESS=off -j2 || fail "make -j2 failed"
# The room is a few metres across; the scan makes the merged mesh accurate to a few centimetres.
check_below "merged accuracy median (m)" "$(metric "$work/reports/eval-mesh-merged.report.json" accuracy_median)" 0.05
check_below "refined accuracy median (m)" "$(metric "$work/reports/eval-mesh-refined.report.json" accuracy_median)" 0.05
check_below "panorama mesh accuracy median (m)" "$(metric "$work/reports/eval-mesh-panorama.report.json" accuracy_median)" 0.2
[ -z "$(make -f pipelines/synth-scenario3.mk WORK="$work" PG_BIN="$bin" PROGRESS=off -s -n)" ] \
  || fail "a second make would run something"
echo "ok: second make has nothing to do"
