#!/bin/sh
# Regenerates the pictures the README shows: docs/default.png and the depth
# figure docs/depth{1,2,3,6}.png.
#   sh scripts/readme-images.sh      (after `make`)
set -eu
cd "$(dirname "$0")/.."
mkdir -p docs out
build/lancer render scenes/default.scn -o out/default.exr --png docs/default.png -q
for d in 1 2 3 6; do
    build/lancer render "scenes/parity/depth$d.scn" -o "out/depth$d.exr" --png "docs/depth$d.png" -q
done
