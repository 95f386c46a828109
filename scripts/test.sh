#!/usr/bin/env bash
# Sets up, builds and runs every test.
# Usage: scripts/test.sh              all tests (Release)
#        scripts/test.sh --sanitize   the library unit tests under AddressSanitizer + UBSan
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
jobs="$(nproc)"
if [ "${1:-}" = "--sanitize" ]; then
  # The readers of untrusted input and the numerical core, where memory errors would hide, then the
  # stage libraries' synthetic tests (their real-data tests and the OpenCL kernels' comparisons stay in
  # the Release pass, as do the stage tools' end-to-end tests: under sanitizers they would not fit
  # CI's budget). The flow, refine and sfm unit tests take minutes under ASan and are left out.
  modules=(core geometry camera image mesh eval render synth)
  stage_modules=(remesh spherical track calib depth fusion)
  stage_filter='-*Real*:RemeshBunny.*:TsdfDevice.*'
  targets=()
  for m in "${modules[@]}" "${stage_modules[@]}"; do targets+=("pg_${m}_tests"); done
  ./scripts/build.sh --sanitize --target "${targets[@]}"
  status=0
  run_module() {
    exe=$(find build-sanitize/lib/pg/"$1" -maxdepth 1 -name "pg_${1}_tests" -type f | head -1)
    echo "sanitize: $exe"
    PG_BIN_DIR="$PWD/build-sanitize/bin" "$exe" --gtest_brief=1 "${@:2}" || status=1
  }
  for m in "${modules[@]}"; do run_module "$m"; done
  for m in "${stage_modules[@]}"; do run_module "$m" --gtest_filter="$stage_filter"; done
  exit $status
fi
./scripts/build.sh
ctest --test-dir build --output-on-failure -j "$jobs" --timeout 900
