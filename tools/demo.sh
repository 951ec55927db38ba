#!/usr/bin/env bash
# Sets up, builds (Release) and runs ricci's main job on its embedded default mesh (a genus-2
# surface): describe it, then uniformize it by the hyperbolic Ricci flow.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j"$(nproc)" --target ricci_cli
./build/ricci info
./build/ricci flow
