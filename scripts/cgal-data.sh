#!/bin/sh
# Unpacks the meshes that the exact judge's case 2 and the benchmarks use,
# from Debian's libcgal-demo data, into a build directory (never committed).
#   scripts/cgal-data.sh [DIR]     default build/cgal-data; meshes in DIR/meshes
set -eu
dir=${1:-build/cgal-data}
tarball=/usr/share/doc/libcgal-dev/data.tar.gz
meshes="eight.off anchor.off hand.off couplingdown.off bunny00.off refined_elephant.off armadillo.off ChineseDragon-10kv.off diplodocus.off fandisk_large.off pig.stl sphere.stl"

missing=""
for m in $meshes; do
    [ -s "$dir/meshes/$m" ] || missing="$missing data/meshes/$m"
done
[ -z "$missing" ] && exit 0

if [ ! -r "$tarball" ]; then
    echo "cgal-data: $tarball is missing: install libcgal-demo (scripts/deps.sh test)" >&2
    exit 1
fi
mkdir -p "$dir"
# shellcheck disable=SC2086
tar -xzf "$tarball" -C "$dir" --strip-components=1 $missing
