#!/bin/sh
# Benchmarks (make bench): the speed of each intersection routine, classic
# against robust; then lancer against Embree 3 on the same ray files for
# three CGAL meshes, one thread, alternating pass by pass. Prints Markdown.
#   sh scripts/bench.sh [PASSES]
set -eu
passes=${1:-11}
data=build/cgal-data/meshes
# The figures depend on the processor (Embree picks its code by the ISA), so
# every run names it.
echo "Processor: $(sed -n 's/^model name[^:]*: //p' /proc/cpuinfo | head -n 1), $(nproc) cores;" \
    "AVX2: $(grep -qw avx2 /proc/cpuinfo && echo yes || echo no)," \
    "AVX-512: $(grep -qw avx512f /proc/cpuinfo && echo yes || echo no)"
echo
echo "## Intersection routines (Mrays/s, one thread, medians of 9 alternating rounds)"
echo
build/prim_bench
for m in bunny00 refined_elephant armadillo; do
    mkdir -p "build/bench/$m"
    build/lancer bench --gen-rays "$data/$m.off" "build/bench/$m" 1024 1024 >/dev/null
    echo
    echo "## $m"
    echo
    build/embree_bench "$data/$m.off" "build/bench/$m" "$passes"
done
