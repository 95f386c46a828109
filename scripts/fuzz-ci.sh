#!/usr/bin/env bash
# CI's short fuzz run: every reader fuzz target for a few seconds each (default 30; the total stays
# near 8 minutes for 14 targets on 2 cores), plus every saved regression input. Skipped with a
# message when clang-14 or libFuzzer is missing (scripts/install-deps.sh installs them).
#   scripts/fuzz-ci.sh [seconds-per-target]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-${PG_FUZZ_SECONDS:-30}}"
if ! command -v clang++-14 >/dev/null ||
  ! ls /usr/lib/llvm-14/lib/clang/*/lib/linux/libclang_rt.fuzzer-x86_64.a >/dev/null 2>&1; then
  echo "fuzz-ci: clang-14 / libclang-rt-14-dev not installed; fuzzing skipped"
  exit 0
fi
exec ./fuzz/run.sh "$seconds"
