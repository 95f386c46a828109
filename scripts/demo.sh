#!/usr/bin/env bash
# Sets up, builds and runs scenario 2 on the built-in synthetic set end to end (pipelines/demo.mk):
# pg-synth -> pg-calib (board) -> pg-track -> pg-depth -> pg-merge -> pg-refine -> pg-remesh, and the
# panorama pair (pg-synth room -> pg-sphdepth), then
# prints the final mesh's accuracy against the scene's true mesh, the panorama's range accuracy and the
# time of every job.
# Usage: scripts/demo.sh [output folder, default demo-out] [make variables, e.g. DEMO_VIEWS=24]
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
./scripts/build.sh
out="${1:-demo-out}"
shift || true
make -f pipelines/demo.mk WORK="$out" PG_BIN="$PWD/build/bin" PROGRESS=off -j "$(nproc)" "$@" demo
echo "demo: results in $out (shot report: $out/shot-report.md, $out/shot-report.json)"
