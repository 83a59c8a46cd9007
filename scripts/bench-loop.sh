#!/bin/sh
# The plan's choice between a BVH and a plain loop over the primitives:
# renders scenes of N primitives (spheres, boxes and triangles in turn,
# placed at random with a fixed seed, one point light) with --accel bvh
# and --accel loop, in turns, RUNS times each on one thread, and prints
# per N the median render phase of each and their ratio. The crossover,
# where the loop stops being faster, is PLAN_LOOP_PRIMS (plan.h).
#
#   sh scripts/bench-loop.sh [LANCER] [RUNS]
set -u
LANCER=${1:-build/lancer}
RUNS=${2:-7}
WORK=${LANCER_BENCH_OUT:-build/bench-loop}
mkdir -p "$WORK"
# scene N: N primitives, as described above (awk's rand with a fixed seed)
scene() {
    awk -v n="$1" 'BEGIN {
        srand(n)
        print "image { width 320 height 240 }"
        print "camera { eye 0 3 -12 target 0 0 0 fov 45 }"
        print "light { position 4 9 -6 }"
        print "material m { color 0.7 0.6 0.5 phong 0.3 }"
        for (i = 0; i < n; i++) {
            x = rand() * 8 - 4; y = rand() * 4 - 2; z = rand() * 5 - 2
            if (i % 3 == 0) printf "sphere { center %g %g %g radius %g material m }\n", x, y, z, 0.3 + rand() * 0.7
            else if (i % 3 == 1) printf "box { min %g %g %g max %g %g %g material m }\n", x, y, z, x + 0.8, y + 0.8, z + 0.8
            else printf "triangle { a %g %g %g b %g %g %g c %g %g %g material m }\n", x, y, z, x + 1.2, y, z, x, y + 1.2, z + 0.3
        }
    }'
}
render_s() {
    sed -n 's/.*"phases_s": {[^}]*"render": \([0-9.]*\).*/\1/p' "$WORK/stats.json"
}
median() { sort -g | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }
echo "| primitives | BVH s | loop s | BVH / loop |"
echo "| --- | --- | --- | --- |"
for n in 1 2 3 4 6 8 12 16 24 32; do
    scene "$n" >"$WORK/n$n.scn"
    : >"$WORK/bvh.t"
    : >"$WORK/loop.t"
    i=0
    while [ "$i" -lt "$RUNS" ]; do
        for kind in bvh loop; do
            "$LANCER" render "$WORK/n$n.scn" -o "$WORK/out.exr" --threads 1 -q --accel "$kind" --stats "$WORK/stats.json" || exit 1
            render_s >>"$WORK/$kind.t"
        done
        i=$((i + 1))
    done
    b=$(median <"$WORK/bvh.t")
    l=$(median <"$WORK/loop.t")
    echo "| $n | $b | $l | $(awk -v b="$b" -v l="$l" 'BEGIN { printf "%.2f", b / l }') |"
done
