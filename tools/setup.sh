#!/usr/bin/env bash
# Installs the Debian 12 packages ricci needs to build and test. Idempotent: installs only what
# is missing and does nothing (not even 'apt-get update') when everything is present.
#   bash tools/setup.sh [--peers]    (--peers: also the benchmark-only peers' packages)
set -euo pipefail

peers=0
for arg in "$@"; do
  case "$arg" in
    --peers) peers=1 ;;
    *) echo "setup: unknown option '$arg' (usage: tools/setup.sh [--peers])" >&2; exit 2 ;;
  esac
done

packages=(
  g++ make cmake          # toolchain (CMake >= 3.20)
  libgomp1                # OpenMP runtime (per-face parallel loops)
  libeigen3-dev           # Eigen: dense and sparse linear algebra
  libceres-dev            # Ceres Solver: least-squares fits (deck transformations)
  libsuitesparse-dev      # SuiteSparse/CHOLMOD: sparse Cholesky for Newton's method
  libqd-dev               # QD: quad-double arithmetic (canonical polygons beyond quad)
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
  python3-dev             # Python headers: the module ricci (lib/python)
  pybind11-dev            # pybind11: the module's bindings
  python3-numpy           # numpy: the module's arrays
  python3-distributed     # Dask distributed: ricci batch
  python3-psutil          # psutil: the batch test finds and kills a Dask worker
  python3-pytest          # pytest: the Python tests (tests/python)
  python3-matplotlib      # matplotlib: the README's Python example plots the layout
  python3-venv            # venv (and pip): the pip install check (tools/check_python_install.sh)
  python3-setuptools      # setuptools and wheel: pip builds the module offline (--no-build-isolation)
  python3-wheel
)
# Only with --peers: what the benchmark-only peers need (never the library, CLI or tests).
if [ "$peers" -eq 1 ]; then
  packages+=(
    libcgal-dev           # CGAL (header-only): tools/peer_cgal, cmake -DRICCI_PEERS=ON
    python3-numpy         # tools/bench_peers.py: the subdivided meshes it writes
  )
fi

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
