#!/bin/sh
# Speed against POV-Ray: renders every parity scene with both renderers, at
# one thread and at every thread, alternating run by run, and prints a
# Markdown table of median times and the ratio POV-Ray / lancer (above 1:
# lancer is faster). Not a test: times on a shared machine are noisy, which
# is why the two renderers alternate and only medians are compared.
#
#   sh scripts/bench-pov.sh [LANCER] [RUNS] [SCALE]
#
# LANCER defaults to build/lancer, RUNS (per renderer and setting) to 5,
# SCALE (image size multiplier, so that times are well above POV-Ray's 1 ms
# resolution) to 4. POV-Ray's time is the "Trace Time" of its statistics;
# lancer's the "render" phase of --stats: both leave out parsing and start-up.
set -eu
LANCER=${1:-build/lancer}
RUNS=${2:-5}
SCALE=${3:-4}
ALL=$(nproc)
WORK=build/bench-pov
mkdir -p "$WORK"

median() { sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }

echo "| scene | size | threads | POV-Ray trace (s) | lancer render (s) | POV-Ray / lancer |"
echo "| --- | --- | --- | --- | --- | --- |"
for scn in scenes/parity/*.scn; do
    name=$(basename "$scn" .scn)
    read -r w h k <<SIZE
$("$LANCER" export-pov "$scn" -o - | sed -n 's|^// lancer-reference: width \([0-9]*\) height \([0-9]*\) spp \([0-9]*\)$|\1 \2 \3|p')
SIZE
    w=$((w * SCALE))
    h=$((h * SCALE))
    "$LANCER" export-pov "$scn" -o "$WORK/$name.pov" --width "$w" --height "$h"
    for t in 1 "$ALL"; do
        : >"$WORK/pov.times"
        : >"$WORK/lancer.times"
        for _ in $(seq "$RUNS"); do
            povray -D -V -A "+W$((w * k))" "+H$((h * k))" "+WT$t" +FE "+O$WORK/pov.exr" "+I$WORK/$name.pov" \
                >"$WORK/pov.log" 2>&1
            sed -n 's/.*Trace Time:.*(\([0-9.]*\) seconds).*/\1/p' "$WORK/pov.log" >>"$WORK/pov.times"
            "$LANCER" render "$scn" --width "$w" --height "$h" --threads "$t" -q -o "$WORK/lancer.exr" \
                --stats "$WORK/stats.json"
            sed -n 's/.*"phases_s": {[^}]*"render": \([0-9.]*\).*/\1/p' "$WORK/stats.json" >>"$WORK/lancer.times"
        done
        p=$(median <"$WORK/pov.times")
        l=$(median <"$WORK/lancer.times" | awk '{printf "%.3f", $1}')
        echo "| $name | ${w}x$h$([ "$k" -gt 1 ] && echo " (${k}x$k spp)") | $t | $p | $l | $(awk -v p="$p" -v l="$l" 'BEGIN {printf "%.2f", p / l}') |"
    done
done
