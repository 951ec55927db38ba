#!/usr/bin/env bash
# Builds the libFuzzer targets of tools/fuzz with clang + AddressSanitizer + UBSan and runs each
# for a short while on a copy of its seed corpus (tools/fuzz/corpus/<target>, never written to).
#
#   tools/fuzz_smoke.sh [SECONDS] [BUILD_DIR]     defaults: 30 seconds per target, build-fuzz
#
# Environment: RICCI_FUZZ_CXX (default clang++-14), RICCI_FUZZ_CXXFLAGS (default "-g1 -O1"; -g1:
# line tables only, reports keep file and line), RICCI_FUZZ_TARGETS (default: all of obj off
# ply ply_body target load stl freesurfer gifti). Exits non-zero when a target fails to build or finds a
# crash, a sanitizer report, an invariant violation, a timeout (> 10 s) or an input using more
# than 2 GB; the input is kept in BUILD_DIR/fuzz-artifacts/ and the log in BUILD_DIR/fuzz-logs/.
# Reproduce with: BUILD_DIR/tools/fuzz/fuzz_TARGET BUILD_DIR/fuzz-artifacts/TARGET-crash-…
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-30}"
build="${2:-build-fuzz}"
cxx="${RICCI_FUZZ_CXX:-clang++-14}"
flags="${RICCI_FUZZ_CXXFLAGS:--g1 -O1}"
targets=(${RICCI_FUZZ_TARGETS:-obj off ply ply_body target load stl freesurfer gifti})

if ! command -v "$cxx" >/dev/null 2>&1; then
  echo "fuzz_smoke: $cxx not found. On Debian: apt-get install clang-14 libclang-rt-14-dev libfuzzer-14-dev (or run tools/setup.sh)" >&2
  exit 1
fi

cmake -S . -B "$build" -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="$flags" \
  -DRICCI_SANITIZE=address,undefined -DRICCI_FUZZ=ON -DRICCI_BUILD_CLI=OFF -DRICCI_BUILD_TESTS=OFF \
  -DRICCI_BUILD_TOOLS=ON >/dev/null
cmake --build "$build" -j"$(nproc)" --target ricci_fuzzers

artifacts="$build/fuzz-artifacts"
logs="$build/fuzz-logs"
mkdir -p "$artifacts" "$logs"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:symbolize=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"

failed=()
start=$SECONDS
for t in "${targets[@]}"; do
  # The committed seeds are copied: libFuzzer adds new inputs to its first corpus directory.
  cp -r "tools/fuzz/corpus/$t" "$work/$t"
  dict=()
  case "$t" in
    obj | off | ply | target | load | gifti) dict=(-dict="tools/fuzz/$t.dict") ;;
  esac
  log="$logs/$t.log"
  set +e
  "$build/tools/fuzz/fuzz_$t" "$work/$t" "${dict[@]}" -max_total_time="$seconds" -timeout=10 \
    -rss_limit_mb=2048 -print_final_stats=1 -artifact_prefix="$artifacts/$t-" >"$log" 2>&1
  rc=$?
  set -e
  execs="$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)"
  rate="$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)"
  cov="$(grep -o 'cov: [0-9]* ft: [0-9]*' "$log" | tail -1)"
  if [ "$rc" -ne 0 ]; then
    failed+=("$t")
    echo "fuzz_smoke: $t FAILED (exit $rc) after ${execs:-?} executions; log: $log" >&2
    grep -E 'ERROR|runtime error|invariant violated|SUMMARY|Test unit written' "$log" | head -20 >&2 || true
  else
    echo "fuzz_smoke: $t ok: ${execs:-?} executions (${rate:-?}/s), ${cov:-cov ?} in ${seconds} s"
  fi
done
echo "fuzz_smoke: ${#targets[@]} targets in $((SECONDS - start)) s"
if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz_smoke: failures in: ${failed[*]} (inputs in $artifacts)" >&2
  exit 1
fi
