#!/usr/bin/env bash
# Regenerates the README's pictures (tools/pictures/) from `ricci uniformize` on the embedded
# default mesh. Needs a built ricci in build/ (bash tools/demo.sh builds it; RICCI_BUILD=dir for another).
set -euo pipefail
cd "$(dirname "$0")/.."
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
"${RICCI_BUILD:-build}/ricci" uniformize -o "$out/run" -q > /dev/null
cp "$out/run/polygon.png" tools/pictures/genus2-polygon.png
cp "$out/run/checker-1.png" tools/pictures/genus2-checker.png
cp "$out/run/cover.png" tools/pictures/genus2-cover.png
echo "readme_pictures: wrote tools/pictures/genus2-{polygon,checker,cover}.png"
