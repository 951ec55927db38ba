#!/usr/bin/env bash
# Checks both ways of installing the Python module `ricci` from a configured and built tree:
#   1. pip install into a new virtual environment (--system-site-packages: numpy and Dask from
#      Debian; --no-build-isolation --no-index: offline), reusing the build directory
#      (RICCI_BUILD_DIR; without it, setup.py configures and builds the library afresh);
#   2. cmake --install into a temporary prefix, the package then imported from
#      <prefix>/lib/python3.X/site-packages.
# Each installed copy runs the embedded default from outside the source tree.
#   bash tools/check_python_install.sh [build-dir (default: build)]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "${1:-$root/build}" && pwd)"
[[ -f "$build/CMakeCache.txt" ]] || { echo "check_python_install: $build is not a configured build directory" >&2; exit 2; }
python="$(sed -n 's/^RICCI_PYTHON:[A-Z]*=//p' "$build/CMakeCache.txt")"
[[ -n "$python" ]] || { echo "check_python_install: $build was configured without the Python module" >&2; exit 2; }

tmp="$(mktemp -d "${TMPDIR:-/tmp}/ricci-python-install.XXXXXX")"
trap 'rm -rf "$tmp"' EXIT
log="$tmp/log"
step() {  # runs a step quietly; shows its output when it fails
  if ! "$@" >>"$log" 2>&1; then
    cat "$log" >&2
    echo "check_python_install: FAILED: $*" >&2
    exit 1
  fi
}
probe='import ricci, sys; r = ricci.uniformize(seed_checks=0); assert r.ok and r.uv.shape[1:] == (3, 2); print(ricci.__file__)'

step "$python" -m venv --system-site-packages "$tmp/venv"
step env RICCI_BUILD_DIR="$build" "$tmp/venv/bin/pip" install --no-build-isolation --no-index "$root/lib/python"
where="$(cd "$tmp" && "$tmp/venv/bin/python" -c "$probe")"
[[ "$where" == "$tmp/venv/"* ]] || { echo "check_python_install: FAILED: pip's ricci imported from $where" >&2; exit 1; }
echo "check_python_install: OK: pip install into a venv ($where)"

step cmake --install "$build" --prefix "$tmp/prefix"
site="$(cd "$tmp/prefix" && ls -d lib*/python3*/site-packages | head -1)"
where="$(cd "$tmp" && PYTHONPATH="$tmp/prefix/$site" "$python" -c "$probe")"
[[ "$where" == "$tmp/prefix/"* ]] || { echo "check_python_install: FAILED: the installed ricci imported from $where" >&2; exit 1; }
echo "check_python_install: OK: cmake --install ($site/ricci)"
