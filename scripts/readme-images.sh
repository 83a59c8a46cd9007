#!/bin/sh
# Regenerates the pictures the README shows: docs/default.png and the depth
# figure docs/depth{1,2,3,6}.png, and the stability figure docs/stability-*.png.
#   sh scripts/readme-images.sh      (after `make`)
set -eu
cd "$(dirname "$0")/.."
mkdir -p docs out
build/lancer render scenes/default.scn -o out/default.exr --png docs/default.png -q
for d in 1 2 3 6; do
    build/lancer render "scenes/parity/depth$d.scn" -o "out/depth$d.exr" --png "docs/depth$d.png" -q
done
# The stability figure: the contact scene translated by 1e5, robust and
# classic, with the classic render's heat map against its unit render.
S=scenes/stability/contact.scn
build/lancer render "$S" -o out/contact.exr --png docs/stability-unit.png -q
build/lancer render "$S" -o out/contact-robust.exr --png docs/stability-robust.png -q --translate 1e5,1e5,1e5
build/lancer render "$S" -o out/contact-classic-unit.exr -q --classic
build/lancer render "$S" -o out/contact-classic.exr --png docs/stability-classic.png -q --classic \
    --translate 1e5,1e5,1e5
build/lancer diff out/contact-classic-unit.exr out/contact-classic.exr --heatmap docs/stability-classic-heat.png \
    >/dev/null
