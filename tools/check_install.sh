#!/usr/bin/env bash
# Checks that the installed library is usable: installs a configured and built tree into a
# temporary prefix, builds tests/consumer against it with find_package(ricci) and runs it.
#   cmake -S . -B build -DCMAKE_BUILD_TYPE=Release && cmake --build build -j2
#   bash tools/check_install.sh [build-dir (default: build)] [mesh file for the consumer]
# A sanitizer build (RICCI_SANITIZE) installs an instrumented libricci.a; the consumer is then
# linked with the same -fsanitize option.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "${1:-$root/build}" && pwd)"
shift || true
[[ -f "$build/CMakeCache.txt" ]] || { echo "check_install: $build is not a configured build directory" >&2; exit 2; }

tmp="$(mktemp -d "${TMPDIR:-/tmp}/ricci-install.XXXXXX")"
trap 'rm -rf "$tmp"' EXIT
log="$tmp/log"

step() {  # runs a step quietly; shows its output when it fails
  if ! "$@" >>"$log" 2>&1; then
    cat "$log" >&2
    echo "check_install: FAILED: $*" >&2
    exit 1
  fi
}
build_type="$(sed -n 's/^CMAKE_BUILD_TYPE:[A-Z]*=//p' "$build/CMakeCache.txt")"
sanitize="$(sed -n 's/^RICCI_SANITIZE:[A-Z]*=//p' "$build/CMakeCache.txt")"
step cmake --build "$build" --target ricci -j2
step cmake --install "$build" --prefix "$tmp/prefix"
step cmake -S "$root/tests/consumer" -B "$tmp/consumer-build" -DCMAKE_PREFIX_PATH="$tmp/prefix" \
  -DCMAKE_BUILD_TYPE="${build_type:-Release}" ${sanitize:+-DCMAKE_EXE_LINKER_FLAGS="-fsanitize=$sanitize"}
step cmake --build "$tmp/consumer-build" -j2
if ! result="$("$tmp/consumer-build/consumer" "$@" 2>&1)"; then
  echo "$result" >&2
  echo "check_install: FAILED: the consumer built against the installed package failed" >&2
  exit 1
fi
echo "check_install: OK: find_package(ricci) from the installed prefix; $result"
