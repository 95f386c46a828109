#!/usr/bin/env bash
# Builds the reader fuzz targets with clang (libFuzzer + ASan + UBSan) and runs each one.
#   fuzz/run.sh [seconds-per-target] [target...]     default: 60 seconds, every target
# Seeds: formats/examples/, fuzz/seeds/ and testdata/fuzz-regressions/<target>/. The growing corpus
# is kept in <build>/corpus/<target>; a crash, hang (> 10 s) or leak leaves its input in
# <build>/artifacts/ and makes the script exit 1. Environment: PG_FUZZ_BUILD (default build-fuzz),
# PG_FUZZ_JOBS (parallel build jobs, default 2), CXX (default clang++-14).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
seconds="${1:-60}"
shift || true
build="${PG_FUZZ_BUILD:-$root/build-fuzz}"
examples="$root/formats/examples"
seeds="$root/fuzz/seeds"
regressions="$root/testdata/fuzz-regressions"

all_targets=(cameras depth_exr image ply_mesh point_cloud obj vertex_mask tracks pg_json flo brush_strokes exif
  scan scan_lists)
targets=("${@:-${all_targets[@]}}")

if [ ! -f "$build/build.ninja" ]; then
  CC="${CC:-clang-14}" CXX="${CXX:-clang++-14}" cmake -S "$root" -B "$build" -G Ninja \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -DNDEBUG" -DPG_BUILD_FUZZERS=ON -DPG_BUILD_TESTS=OFF -DPG_BUILD_BENCH=OFF >/dev/null
fi
ninja -C "$build" -j"${PG_FUZZ_JOBS:-2}" $(printf 'fuzz/fuzz_%s ' "${targets[@]}") >/dev/null

# The seed files of a target, one a line.
seed_files() {
  case "$1" in
    cameras) ls "$examples"/cameras.json "$examples"/eval-cameras.json ;;
    depth_exr) ls "$examples"/*.exr "$seeds"/image/*.exr ;;
    image) ls "$examples"/*.png "$examples"/*.exr "$seeds"/image/* ;;
    ply_mesh | point_cloud) ls "$examples"/*.ply "$seeds"/ply/* ;;
    obj) ls "$examples"/*.obj ;;
    vertex_mask) ls "$examples"/*.pgmask.json ;;
    tracks) ls "$examples"/tracks.json ;;
    pg_json) ls "$examples"/*.json ;;
    flo) ls "$seeds"/flo/* ;;
    brush_strokes) ls "$examples"/brush-strokes.json ;;
    exif) ls "$seeds"/exif/* ;;
    scan) ls "$examples"/*.ply "$seeds"/ply/* "$seeds"/scan/* ;;
    scan_lists) ls "$examples"/rgbd-poses.txt "$seeds"/scan_lists/* ;;
  esac
  if [ -d "$regressions/$1" ]; then find "$regressions/$1" -type f; fi
}

dict_of() {
  case "$1" in
    ply_mesh | point_cloud | scan) echo "$root/fuzz/dicts/ply.dict" ;;
    obj) echo "$root/fuzz/dicts/obj.dict" ;;
    depth_exr | image | flo | exif | scan_lists) echo "" ;;
    *) echo "$root/fuzz/dicts/json.dict" ;;
  esac
}

export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}"
mkdir -p "$build/artifacts" "$build/logs"
failed=0
printf '%-14s %10s %8s %8s %8s  %s\n' target execs exec/s cov ft result
for t in "${targets[@]}"; do
  corpus="$build/corpus/$t"
  mkdir -p "$corpus"
  seed_files "$t" | while read -r f; do cp -f "$f" "$corpus/seed-$(basename "$f")"; done
  dict="$(dict_of "$t")"
  log="$build/logs/$t.log"
  result=ok
  "$build/fuzz/fuzz_$t" "$corpus" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
    -max_len=65536 -print_final_stats=1 -artifact_prefix="$build/artifacts/$t-" \
    ${dict:+-dict="$dict"} >"$log" 2>&1 || { result="FINDING (see $log)"; failed=1; }
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log")
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log")
  cov=$(grep -oE 'cov: [0-9]+ ft: [0-9]+' "$log" | tail -1)
  printf '%-14s %10s %8s %8s %8s  %s\n' "$t" "${execs:-?}" "${rate:-?}" \
    "$(echo "$cov" | awk '{print $2}')" "$(echo "$cov" | awk '{print $4}')" "$result"
done
exit "$failed"
