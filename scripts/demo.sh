#!/usr/bin/env bash
# Sets up, builds and runs the whole pipeline that exists on the built-in demo scene.
# Usage: scripts/demo.sh [output folder, default demo-out]
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
./scripts/build.sh
out="${1:-demo-out}"
make -f pipelines/demo.mk OUT="$out" PG_BIN="$PWD/build/bin" -j "$(nproc)"
echo "demo: results in $out (open $out/report.json for the run reports)"
