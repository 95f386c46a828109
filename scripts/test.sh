#!/usr/bin/env bash
# Sets up, builds and runs every test.
# Usage: scripts/test.sh              all tests (Release)
#        scripts/test.sh --sanitize   the suite under AddressSanitizer + UBSan
#        scripts/test.sh --sanitize -E REGEX   ... without the tests REGEX names (any ctest options)
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
jobs="$(nproc)"
if [ "${1:-}" = "--sanitize" ]; then
  # The whole suite, built with ASan+UBSan (clang where installed, see scripts/build.sh): the OpenCL
  # comparisons too (the host side is checked, PoCL's JIT-compiled kernels are not), the real-data
  # tests where ../shared/data is present, and the pipelines. A test that fails is run once more
  # and fails the pass only if it fails again: LeakSanitizer's tracer has crashed (signal 11) at the
  # exit of a test with PoCL's threads alive, once in some 500 test runs.
  ./scripts/build.sh --sanitize
  shift
  exec ctest --test-dir build-sanitize --output-on-failure -j "$jobs" --timeout 1200 --repeat until-pass:2 "$@"
fi
./scripts/build.sh
ctest --test-dir build --output-on-failure -j "$jobs" --timeout 900
