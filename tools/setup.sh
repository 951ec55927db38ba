#!/usr/bin/env bash
# Installs the Debian 12 packages ricci needs to build and test. Idempotent: installs only what
# is missing and does nothing (not even 'apt-get update') when everything is present.
set -euo pipefail

packages=(
  g++ make cmake          # toolchain (CMake >= 3.20)
  libgomp1                # OpenMP runtime (per-face parallel loops)
  libeigen3-dev           # Eigen: dense and sparse linear algebra
  libceres-dev            # Ceres Solver: least-squares fits (deck transformations)
  libsuitesparse-dev      # SuiteSparse/CHOLMOD: sparse Cholesky for Newton's method
  doctest-dev             # doctest: the test framework
  libcli11-dev            # CLI11: command-line parsing
  nlohmann-json3-dev      # nlohmann-json: JSON reports
  pkg-config              # finds cairo
  libcairo2-dev           # cairo: PNG and SVG pictures
  libfontconfig-dev       # fontconfig: fonts for the pictures' text (released at exit)
  chromium                # headless browser: the report.html test
  clang-14                # clang: builds the libFuzzer targets (tools/fuzz_smoke.sh)
  libclang-rt-14-dev      # clang runtimes: AddressSanitizer, UBSan for the fuzz build
  libfuzzer-14-dev        # libFuzzer: the fuzzing engine of tools/fuzz
  libomp-14-dev           # OpenMP for clang (libgomp serves g++ only): the fuzz build
  universal-ctags         # function extents for tools/longest_functions.sh (printed by the check)
  libexpat1-dev           # expat: the XML of GIFTI surfaces and overlays
  zlib1g-dev              # zlib: GIFTI's GZipBase64Binary data
  libtinygltf-dev         # tinygltf: the textured mesh.glb of ricci uniformize
  python3-nibabel         # nibabel: tests read and write GIFTI and FreeSurfer files independently
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed'; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages present"
  exit 0
fi

sudo=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then sudo="sudo"; else
    echo "setup: missing packages: ${missing[*]}; run as root or install them with apt-get" >&2
    exit 1
  fi
fi
echo "setup: installing ${missing[*]}"
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
