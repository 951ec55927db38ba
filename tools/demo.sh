#!/usr/bin/env bash
# Sets up, builds (Release) and runs ricci's main job on its embedded default mesh (a genus-2
# surface): flow, cut, layout, deck transformations, pictures and report, written to build/demo/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j"$(nproc)" --target ricci_cli
./build/ricci uniformize -o build/demo
echo "demo: open build/demo/report.html (pictures, numbers); meshes and generators are beside it"
