#!/bin/sh
# Regenerates the picture the README shows: docs/default.png.
#   sh scripts/readme-images.sh      (after `make`)
set -eu
cd "$(dirname "$0")/.."
mkdir -p docs
build/lancer render scenes/default.scn -o out/default.exr --png docs/default.png -q
