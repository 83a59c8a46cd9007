#!/bin/sh
# Ray benchmarks (make bench): the speed of each intersection routine,
# classic against robust; then lancer against Embree 3 robust on the same
# ray files, for six CGAL meshes, each framed loosely and tightly, one
# thread, alternating pass by pass. Prints Markdown; appends each measured
# ratio to RESULTS (scripts/bench-table.sh).
#   sh scripts/bench.sh RESULTS [PASSES]
set -eu
results=$1
passes=${2:-11}
data=build/cgal-data/meshes
echo "## Intersection routines (Mrays/s, one thread, medians of 9 alternating rounds)"
echo
build/prim_bench
echo
echo "## Rays against Embree 3 robust (one thread, medians of $passes alternating passes)"
echo
for m in bunny00 refined_elephant armadillo ChineseDragon-10kv diplodocus fandisk_large; do
    for f in loose tight; do
        mkdir -p "build/bench/$m/$f"
        build/lancer bench --gen-rays "$data/$m.off" "build/bench/$m/$f" 1024 1024 \
            $([ "$f" = tight ] && echo --tight) >/dev/null
    done
    build/embree_bench "$data/$m.off" "$passes" "$results" "build/bench/$m/loose" "build/bench/$m/tight"
done
