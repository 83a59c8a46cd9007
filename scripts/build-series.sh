#!/bin/sh
# The BVH's build time and memory against the triangle count: builds the
# series of `lancer bench --build-series` (bunny00 split in two, again and
# again, up to 10 million triangles) and plots it to docs/build-series.png
# with gnuplot (Debian gnuplot-nox, installed here when missing and root).
#   sh scripts/build-series.sh      (after `make` and `make cgal-data`)
set -eu
cd "$(dirname "$0")/.."
if ! command -v gnuplot >/dev/null; then
    if [ "$(id -u)" -eq 0 ]; then
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq gnuplot-nox >/dev/null
    else
        echo "build-series: run: sudo apt-get install -y gnuplot-nox" >&2
        exit 1
    fi
fi
mkdir -p build docs
build/lancer bench --build-series build/cgal-data/meshes/bunny00.off | tee build/build-series.md
# the table's rows as columns: triangles, ms (1 thread), ms (2 threads), ns per triangle, bytes
sed -n 's/^| \([0-9]\{1,\}\) | \([0-9.]*\) | \([0-9.]*\) | \([0-9.]*\) | \([0-9.]*\) |$/\1 \2 \3 \4 \5/p' \
    build/build-series.md >build/build-series.dat
gnuplot <<'GP'
set terminal pngcairo size 900,380 font ",10"
set output "docs/build-series.png"
set multiplot layout 1,2 title "lancer BVH build, bunny00 split up to 10M triangles"
set logscale xy
set xlabel "triangles"
set ylabel "build time (ms)"
set key top left
set grid
plot "build/build-series.dat" using 1:2 with linespoints title "1 thread", \
     "" using 1:3 with linespoints title "2 threads", \
     "" using 1:($1*1e-3) with lines dashtype 2 title "linear (1 us per triangle)"
unset logscale y
set logscale x
set ylabel "bytes per triangle (BVH)"
set yrange [0:200]
plot "build/build-series.dat" using 1:5 with linespoints title "memory"
unset multiplot
GP
echo "build-series: docs/build-series.png"
