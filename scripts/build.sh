#!/usr/bin/env bash
# Configures and builds pg (Release, warnings on, ccache when present, -j from the core count).
# Usage: scripts/build.sh [--sanitize | --cuda] [--target T...]
#   --sanitize: ASan+UBSan build in build-sanitize/
#   --cuda:     the CUDA flow kernels too (PG_WITH_CUDA, nvcc on PATH or in /usr/local/cuda) in build-cuda/
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=build
args=(-DCMAKE_BUILD_TYPE=Release)
if [ "${1:-}" = "--sanitize" ]; then
  shift
  build_dir=build-sanitize
  # -O1 -g1: a third of the compile time of -O2 -g under ASan+UBSan, still with file:line stacks.
  args=(-DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1 -DNDEBUG"
    "-DCMAKE_C_FLAGS_RELWITHDEBINFO=-O1 -g1 -DNDEBUG" -DPG_SANITIZE=ON -DPG_BUILD_BENCH=OFF)
  # clang-14 where installed (scripts/install-deps.sh does): it compiles this tree about a quarter
  # faster than GCC 12 under the sanitizers, and its UBSan checks more (function, vptr). GCC otherwise.
  if command -v clang++-14 >/dev/null && [ ! -f "$build_dir/CMakeCache.txt" ]; then
    export CC=clang-14 CXX=clang++-14
  fi
elif [ "${1:-}" = "--cuda" ]; then
  shift
  build_dir=build-cuda
  nvcc="$(command -v nvcc || echo /usr/local/cuda/bin/nvcc)"
  args=(-DCMAKE_BUILD_TYPE=Release -DPG_WITH_CUDA=ON "-DCMAKE_CUDA_COMPILER=$nvcc" -DPG_BUILD_BENCH=OFF)
fi
generator=()
if command -v ninja >/dev/null; then generator=(-G Ninja); fi
if [ ! -f "$build_dir/CMakeCache.txt" ]; then
  cmake -S . -B "$build_dir" "${generator[@]}" "${args[@]}"
fi
cmake --build "$build_dir" -j "$(nproc)" "$@"
