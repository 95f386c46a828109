#!/bin/sh
# Scenario 1 (pipelines/synth-scenario1.mk): refinement of the "deform" scene's modelled mesh brings
# it towards the true mesh; remeshing keeps that accuracy.
# Usage: scenario1_test.sh TOOLS_DIR WORK_DIR   (from the repository root)
. "$(dirname "$0")/lib.sh"
bin="$1"; work="$2"
rm -rf "$work"
make -f pipelines/synth-scenario1.mk WORK="$work" PG_BIN="$bin" PROGRESS=off -j2 || fail "make -j2 failed"
model=$(metric "$work/reports/eval-mesh-model.report.json" accuracy_mean)
refined=$(metric "$work/reports/eval-mesh-refined.report.json" accuracy_mean)
remeshed=$(metric "$work/reports/eval-mesh-remeshed.report.json" accuracy_mean)
# The deformation is up to 4 cm: refinement must remove at least a third of the mean error.
check_below "refined accuracy mean (model $model)" "$refined" "$(awk -v m="$model" 'BEGIN { print m * 0.67 }')"
check_below "remeshed accuracy mean (refined $refined)" "$remeshed" "$(awk -v r="$refined" 'BEGIN { print r * 1.2 + 0.001 }')"
[ -z "$(make -f pipelines/synth-scenario1.mk WORK="$work" PG_BIN="$bin" PROGRESS=off -s -n)" ] \
  || fail "a second make would run something"
echo "ok: second make has nothing to do"
