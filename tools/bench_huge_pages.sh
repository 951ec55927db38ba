#!/bin/bash
# bench_huge_pages — the whole `ricci uniformize --no-pictures` process with malloc on huge pages
# (the default, cli/huge_pages.h) and without (RICCI_HUGE_PAGES=0), in alternated rounds: wall
# seconds, peak resident MB, minor page faults and the flow stage's seconds per run.
#   bash tools/bench_huge_pages.sh [MESH] [ROUNDS]
# MESH defaults to ../shared/meshes/derived/kitten-425k-midpoint-subdiv.off, ROUNDS to 3.
# Needs a Release build in build/ and GNU time (/usr/bin/time).
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
mesh="${1:-$here/../shared/meshes/derived/kitten-425k-midpoint-subdiv.off}"
rounds="${2:-3}"
ricci="$here/build/ricci"
[ -x "$ricci" ] || { echo "bench_huge_pages: no $ricci (build first)" >&2; exit 2; }
[ -f "$mesh" ] || { echo "bench_huge_pages: no mesh $mesh" >&2; exit 2; }
[ -x /usr/bin/time ] || { echo "bench_huge_pages: needs GNU time (/usr/bin/time)" >&2; exit 2; }
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
echo "| round | huge pages | wall s | peak MB | minor faults | flow s |"
echo "|---:|---|---:|---:|---:|---:|"
for r in $(seq "$rounds"); do
  for on in 1 0; do
    rm -rf "$work/out"
    RICCI_HUGE_PAGES=$on /usr/bin/time -f "%e %M %R" -o "$work/time" \
      "$ricci" uniformize "$mesh" -o "$work/out" --no-pictures --json -q > "$work/report.json"
    read -r wall kb faults < "$work/time"
    flow=$(grep -o '"flow": [0-9.e+-]*' "$work/report.json" | head -1 | awk '{print $2}')
    printf "| %d | %s | %s | %d | %s | %.2f |\n" "$r" "$([ $on = 1 ] && echo on || echo off)" "$wall" $((kb / 1024)) "$faults" "$flow"
  done
done
