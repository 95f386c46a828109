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
  # The readers of untrusted input and the numerical core, where memory errors would hide; the stage
  # tools' end-to-end tests run in the Release pass (under sanitizers they would not fit CI's budget).
  modules=(core geometry camera image mesh eval render synth)
  targets=()
  for m in "${modules[@]}"; do targets+=("pg_${m}_tests"); done
  ./scripts/build.sh --sanitize --target "${targets[@]}"
  status=0
  for m in "${modules[@]}"; do
    exe=$(find build-sanitize/lib/pg/"$m" -maxdepth 1 -name "pg_${m}_tests" -type f | head -1)
    echo "sanitize: $exe"
    PG_BIN_DIR="$PWD/build-sanitize/bin" "$exe" --gtest_brief=1 || status=1
  done
  exit $status
fi
./scripts/build.sh
ctest --test-dir build --output-on-failure -j "$jobs" --timeout 900
