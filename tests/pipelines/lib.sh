# Helpers of the pipeline tests (sourced). Tests exit 0 (pass), 1 (fail) or 77 (skipped).
set -eu
fail() { echo "FAIL: $*" >&2; exit 1; }
# A top-level metric of a pg-eval result (WORK/eval/*.json has the metrics in its run report).
metric() { awk -v key="\"$2\":" '$1 == key { v = $2; sub(/,$/, "", v); print v; exit }' "$1"; }
# Passes when $1 < $2 (floating point).
below() { awk -v a="$1" -v b="$2" 'BEGIN { exit !(a + 0 < b + 0) }'; }
check_below() { # NAME VALUE LIMIT
  [ -n "$2" ] || fail "$1: no value"
  below "$2" "$3" || fail "$1 = $2, expected below $3"
  echo "ok: $1 = $2 < $3"
}
check_above() { # NAME VALUE LIMIT
  [ -n "$2" ] || fail "$1: no value"
  below "$3" "$2" || fail "$1 = $2, expected above $3"
  echo "ok: $1 = $2 > $3"
}
