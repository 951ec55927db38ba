#!/usr/bin/env bash
# Runs `ricci uniformize` on every mesh under ../shared/meshes (bad/ included) with an existing
# build, normally the AddressSanitizer + UndefinedBehaviorSanitizer one, and checks each run:
#   - exit 0 with OUTDIR/report.json free of "nan", or a documented refusal (exit 3–8) with a
#     "ricci: error:" message on stderr and no OUTDIR left behind;
#   - no sanitizer report on stderr, no timeout, no crash (exit 1, 2, 124 or a signal fail).
# It builds nothing. Usage:
#   tools/sanitize_meshes.sh BUILD_DIR [--max-faces N [--large-build DIR2] [--large-args "ARGS"]]
#                            [--pictures-max-faces N] [--timeout S] [MESHES_DIR]
# --max-faces N: meshes with more than N faces (counted from the file; default: no limit) are
# skipped unless --large-build or --large-args is given: then they run with DIR2's ricci (a
# Release build) and/or with the extra uniformize options ARGS (e.g. "--seed-checks 0
# --base-candidates 2", fewer repeats of the same code paths);
# meshes with at most --pictures-max-faces faces (default 6000) also draw the pictures and
# report.html, the others run with --no-pictures. --timeout is per mesh (default 600 s).
# Prints one line per mesh (time, faces, outcome) and the summary
# "N meshes: X ok, Y refused with a message, Z failed"; exits 1 when Z > 0. Without the meshes
# folder it says so and exits 0.
set -uo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
if [[ $# -lt 1 ]]; then
  echo "usage: $0 BUILD_DIR [--max-faces N [--large-build DIR2] [--large-args "ARGS"]] [--pictures-max-faces N] [--timeout S] [MESHES_DIR]" >&2
  exit 2
fi
build="$1"
shift
max_faces=""
large_build=""
large_args=""
pictures_max=6000
per_mesh_timeout=600
meshes="${RICCI_SHARED_MESHES:-$here/../../shared/meshes}"
while [[ $# -gt 0 ]]; do
  case "$1" in
    --max-faces) max_faces="$2"; shift 2 ;;
    --large-build) large_build="$2"; shift 2 ;;
    --large-args) large_args="$2"; shift 2 ;;
    --pictures-max-faces) pictures_max="$2"; shift 2 ;;
    --timeout) per_mesh_timeout="$2"; shift 2 ;;
    *) meshes="$1"; shift ;;
  esac
done
ricci="$build/ricci"
for exe in "$ricci" ${large_build:+"$large_build/ricci"}; do
  if [[ ! -x "$exe" ]]; then
    echo "sanitize_meshes: $exe not found; build the ricci_cli target first" >&2
    exit 2
  fi
done
if [[ ! -d "$meshes" ]]; then
  echo "sanitize_meshes: $meshes not found; skipped"
  exit 0
fi
meshes="$(cd "$meshes" && pwd)"

# Faces declared or listed by a mesh file (polygons count once), without running ricci.
count_faces() {
  case "${1,,}" in
    *.obj) grep -c '^f[[:space:]]' "$1" ;;
    *.off) awk '{ sub(/\r$/, "") } !/^[[:space:]]*#/ && NF > 0 { if (++c == 1 && $1 ~ /OFF$/ && NF == 1) next;
                 if ($1 ~ /OFF$/) { print $3; exit } print $2; exit }' "$1" ;;
    *.ply) awk '{ sub(/\r$/, "") } /^element face/ { print $3; exit } /^end_header/ { print 0; exit }' "$1" ;;
  esac
}

work="$(mktemp -d "${TMPDIR:-/tmp}/ricci-sanitize.XXXXXX")"
trap 'rm -rf "$work"' EXIT
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
sanitizer_pattern='ERROR: AddressSanitizer|ERROR: LeakSanitizer|runtime error:|UndefinedBehaviorSanitizer|SUMMARY: [A-Za-z]*Sanitizer'

total=0 ok=0 refused=0 failed=0 skipped=0
failures=()
while IFS= read -r mesh; do
  name="${mesh#"$meshes"/}"
  faces="$(count_faces "$mesh")"
  faces="${faces:-0}"
  exe="$ricci"
  tag=""
  extra=()
  if [[ -n "$max_faces" && "$faces" -gt "$max_faces" ]]; then
    if [[ -z "$large_build" && -z "$large_args" ]]; then
      printf '%-48s %8s faces  skipped (more than %s faces)\n' "$name" "$faces" "$max_faces"
      skipped=$((skipped + 1))
      continue
    fi
    if [[ -n "$large_build" ]]; then
      exe="$large_build/ricci"
      tag+=" [$large_build]"
    fi
    if [[ -n "$large_args" ]]; then
      read -r -a extra <<<"$large_args"
      tag+=" [$large_args]"
    fi
  fi
  total=$((total + 1))
  out="$work/out-$total"
  pictures=()
  [[ "$faces" -gt "$pictures_max" ]] && pictures=(--no-pictures)
  start=$(date +%s.%N)
  timeout "$per_mesh_timeout" "$exe" uniformize "$mesh" -o "$out" -q "${pictures[@]}" "${extra[@]}" \
    >"$work/stdout" 2>"$work/stderr"
  code=$?
  secs=$(awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }')
  why=""
  if grep -Eq "$sanitizer_pattern" "$work/stderr"; then
    why="sanitizer report"
  elif [[ $code -eq 0 ]]; then
    if [[ ! -s "$out/report.json" ]]; then
      why="exit 0 but no report.json"
    elif grep -Eiq '(^|[^a-z])nan([^a-z]|$)' "$out/report.json"; then
      why="report.json contains nan"
    fi
  elif [[ $code -ge 3 && $code -le 8 ]]; then
    if ! grep -q '^ricci: error: ' "$work/stderr"; then
      why="exit $code without an error message"
    elif [[ -e "$out" ]]; then
      why="exit $code but $out was left behind"
    fi
  elif [[ $code -eq 124 ]]; then
    why="timed out after ${per_mesh_timeout} s"
  else
    why="exit $code"
  fi
  if [[ -n "$why" ]]; then
    failed=$((failed + 1))
    failures+=("$name: $why")
    printf '%-48s %8s faces %7s s  FAILED: %s%s\n' "$name" "$faces" "$secs" "$why" "$tag"
    sed 's/^/    /' "$work/stderr" | tail -n 30
  elif [[ $code -eq 0 ]]; then
    ok=$((ok + 1))
    printf '%-48s %8s faces %7s s  ok%s%s\n' "$name" "$faces" "$secs" "${pictures:+ (no pictures)}" "$tag"
  else
    refused=$((refused + 1))
    msg="$(grep -m1 '^ricci: error: ' "$work/stderr" | cut -c1-110)"
    printf '%-48s %8s faces %7s s  refused (exit %s)%s: %s\n' "$name" "$faces" "$secs" "$code" "$tag" "$msg"
  fi
  rm -rf "$out"
done < <(find -L "$meshes" -type f \( -iname '*.obj' -o -iname '*.off' -o -iname '*.ply' \) | LC_ALL=C sort)

summary="$total meshes: $ok ok, $refused refused with a message, $failed failed"
[[ $skipped -gt 0 ]] && summary+=" ($skipped skipped: more than $max_faces faces)"
if [[ -n "$max_faces" && ( -n "$large_build" || -n "$large_args" ) ]]; then
  summary+=" (above $max_faces faces with ${large_build:-$build}${large_args:+ $large_args})"
fi
echo "$summary"
for f in "${failures[@]}"; do echo "  failed: $f"; done
[[ $failed -eq 0 ]]
