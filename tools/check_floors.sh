#!/usr/bin/env bash
# Checks that the library's stages only call downwards: every file of lib/<stage>/ (sources,
# internal headers, public headers in include/ricci/) includes only headers of its own stage or of
# a stage listed before it in lib/stages.txt. Headers that no stage owns (the standard library,
# Eigen, Ceres, ...) are not checked. Prints each violation as "file: includes header (stage)" and
# exits 1 when there is one; also fails when a header name is owned by two stages or a stage folder
# is missing. Usage: tools/check_floors.sh [LIB_DIR]   (default: lib/ beside this script)
set -euo pipefail
lib=${1:-"$(dirname "$0")/../lib"}
stages=()
while IFS= read -r line; do
  [[ $line =~ ^[a-z] ]] && stages+=("$line")
done < "$lib/stages.txt"
if [ ${#stages[@]} -eq 0 ]; then echo "check_floors: $lib/stages.txt names no stage" >&2; exit 1; fi

declare -A owner floor
status=0
for i in "${!stages[@]}"; do
  s=${stages[$i]}
  floor[$s]=$i
  if [ ! -d "$lib/$s" ]; then echo "check_floors: stage folder $lib/$s is missing" >&2; status=1; continue; fi
  while IFS= read -r h; do
    name=$(basename "$h")
    case $h in */include/ricci/*) key="ricci/$name" ;; *) key="$name" ;; esac
    if [ -n "${owner[$key]:-}" ]; then
      echo "check_floors: $key is owned by both ${owner[$key]} and $s" >&2; status=1
    fi
    owner[$key]=$s
  done < <(find "$lib/$s" -name '*.h' | sort)
done

checked=0
for s in "${stages[@]}"; do
  [ -d "$lib/$s" ] || continue
  while IFS= read -r f; do
    checked=$((checked + 1))
    while IFS= read -r inc; do
      o=${owner[$inc]:-}
      [ -z "$o" ] && continue
      if [ "${floor[$o]}" -gt "${floor[$s]}" ]; then
        echo "${f#"$lib"/}: includes $inc (stage $o, above $s)"
        status=1
      fi
    done < <(sed -n 's/^[[:space:]]*#[[:space:]]*include[[:space:]]*[<"]\([^>"]*\)[>"].*/\1/p' "$f")
  done < <(find "$lib/$s" \( -name '*.h' -o -name '*.cpp' \) | sort)
done
if [ $status -eq 0 ]; then echo "check_floors: ${#stages[@]} stages, $checked files, every include goes to the same or a lower stage"; fi
exit $status
