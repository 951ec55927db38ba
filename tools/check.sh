#!/usr/bin/env bash
# Sets up, builds and runs the whole test suite twice: a Release build (with the Python module and
# its pytest suite), then a build with AddressSanitizer + UndefinedBehaviorSanitizer (Debug
# assertions on); floating-point traps are on in both.
set -euo pipefail
cd "$(dirname "$0")/.."
start="$(date +%s)"
last="$start"
phase() {  # how long the step before took (the whole check should stay under 25 min on 2 cores)
  local now
  now="$(date +%s)"
  echo "check: $1: $((now - last)) s (total $((now - start)) s)"
  last="$now"
}
bash tools/setup.sh
jobs="$(nproc)"
phase setup

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DRICCI_WERROR=ON
cmake --build build -j"$jobs"
phase "Release build"
ctest --test-dir build --output-on-failure -j"$jobs"
phase "Release tests"
# The installed package: cmake --install, then a separate project finds it and links ricci::ricci.
bash tools/check_install.sh build
# The Python module installed both ways (pip into a venv, cmake --install) and imported from there.
bash tools/check_python_install.sh build
phase "install checks"

# -g1: line tables only (the sanitizers' reports keep file and line; the build is faster than with -g).
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-g1 -O1" \
  -DRICCI_SANITIZE=address,undefined -DRICCI_WERROR=ON
# Only what the tests and tools/sanitize_meshes.sh run (the suite, the CLI, the fixture maker and the
# README example); the benchmarks are built once, above.
cmake --build build-asan -j"$jobs" --target ricci_tests
phase "ASan build"
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir build-asan --output-on-failure -j"$jobs"
phase "ASan tests"
# `ricci uniformize` on every ../shared/meshes file under ASan+UBSan (tools/sanitize_meshes.sh) up
# to 30k faces; the larger ones (the same code paths on more faces, 2/3 of this phase's time under
# the sanitizers) are run by the Release build, without the seed-check repeats and with one
# canonical-polygon base, for the same checks of their outcome.
bash tools/sanitize_meshes.sh build-asan --max-faces 30000 --large-build build \
  --large-args "--seed-checks 0 --base-candidates 1" --timeout 600
phase "ASan shared meshes"

# libFuzzer smoke: every reader and load→validate, 4 s each under clang + ASan/UBSan
# (tools/fuzz/README.md); a crash fails the run and leaves its input in build-fuzz/fuzz-artifacts/.
# Unoptimised (-O0): its build is a third shorter, and a smoke run needs few executions.
RICCI_FUZZ_CXXFLAGS="-g1 -O0" bash tools/fuzz_smoke.sh 4
phase "fuzz smoke"

# The house rule of about 150 lines per function: the ten longest of lib/ and cli/ (a report, not
# a gate).
bash tools/longest_functions.sh 10
