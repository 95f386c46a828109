#!/bin/sh
# Gathers the run reports of a recipe's output folder into one shot report:
#   WORK/shot-report.json  {"format": "pg-shot-report", "version": 1, "provenance", "reports": [...]}
#   WORK/shot-report.md    time per job, the evaluations' metrics, links to the pictures.
# Usage: sh pipelines/scripts/shot-report.sh WORK      (plain POSIX sh + awk: runs on any farm node)
set -eu
work="$1"
reports=$(ls "$work"/reports/*.report.json 2>/dev/null || true)
[ -n "$reports" ] || { echo "shot-report: no run reports in $work/reports" >&2; exit 3; }
now=$(date -u +%Y-%m-%dT%H:%M:%SZ)

json="$work/shot-report.json"
{
  printf '{\n"format": "pg-shot-report",\n"version": 1,\n'
  printf '"provenance": {"tool": "pipelines/scripts/shot-report.sh", "version": "0.1.0", '
  printf '"command_line": "sh pipelines/scripts/shot-report.sh %s", "created_utc": "%s", "inputs": [' "$work" "$now"
  sep=""
  for r in $reports; do printf '%s"%s"' "$sep" "$r"; sep=", "; done
  printf ']},\n"reports": [\n'
  sep=""
  for r in $reports; do printf '%s' "$sep"; cat "$r"; sep=","; done
  printf ']\n}\n'
} > "$json.tmp"
mv "$json.tmp" "$json"

# One top-level number of a run report (keys are unique at the top level; nested objects come first
# only for metrics, which never use these names).
field() { awk -v key="\"$2\":" '$1 == key { v = $2; sub(/,$/, "", v); print v; exit }' "$1"; }

md="$work/shot-report.md"
{
  echo "# Shot report: $work"
  echo
  echo "| job | tool | exit | wall s | cpu s | peak MiB |"
  echo "|---|---|---|---|---|---|"
  total=0
  for r in $reports; do
    job=$(basename "$r" .report.json)
    wall=$(field "$r" wall_seconds)
    printf '| %s | %s | %s | %.2f | %.2f | %.0f |\n' "$job" "$(field "$r" tool | tr -d '"')" \
      "$(field "$r" exit_code)" "$wall" "$(field "$r" cpu_seconds)" \
      "$(awk -v b="$(field "$r" peak_memory_bytes)" 'BEGIN { print b / 1048576 }')"
  done
  awk '$1 == "\"wall_seconds\":" { v = $2; sub(/,$/, "", v); s += v } END { printf "\nTotal job time %.1f s.\n", s }' $reports
  for r in $reports; do
    case "$(basename "$r")" in eval-*|calib*|track*|refine*) ;; *) continue ;; esac
    echo
    echo "## $(basename "$r" .report.json)"
    echo
    # The metrics object, one "key: value" line per scalar metric.
    awk '/^  "metrics": \{/ { on = 1; next } on && /^  \}/ { exit }
         on && /^    "[^"]+": [^\[{]/ { line = $0; sub(/^ +/, "", line); sub(/,$/, "", line); gsub(/"/, "", line); print "- " line }' "$r"
  done
  pictures=$(cd "$work" && find . -name '*.png' -not -path './synth*' | sort)
  if [ -n "$pictures" ]; then
    echo
    echo "## Pictures"
    echo
    for p in $pictures; do echo "- [${p#./}](${p#./})"; done
  fi
} > "$md.tmp"
mv "$md.tmp" "$md"
