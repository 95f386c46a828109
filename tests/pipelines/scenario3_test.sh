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
merged=$(metric "$work/reports/eval-mesh-merged.report.json" accuracy_median)
check_below "refined accuracy median (m)" "$(metric "$work/reports/eval-mesh-refined.report.json" accuracy_median)" 0.05
# The panorama pair resolves depth far worse than the scan-backed merge: with the merge's voxel size as
# the mesh's expected error (--mesh-accuracy), refinement must not make the merged mesh worse.
check_below "refined accuracy median over merged" \
  "$(awk -v r="$(metric "$work/reports/eval-mesh-refined.report.json" accuracy_median)" -v m="$merged" 'BEGIN { print r / m }')" 1.5
check_below "panorama mesh accuracy median (m)" "$(metric "$work/reports/eval-mesh-panorama.report.json" accuracy_median)" 0.2
[ -z "$(make -f pipelines/synth-scenario3.mk WORK="$work" PG_BIN="$bin" PROGRESS=off -s -n)" ] \
  || fail "a second make would run something"
echo "ok: second make has nothing to do"
