#!/bin/sh
# Speed against POV-Ray on every parity scene: both renderers at one thread
# and at two, in turns run by run and the runs in rounds over the scenes
# (below), at SCALE times the scene's size (so that times stand well above
# POV-Ray's 1 ms resolution). POV-Ray's time is the "Trace Time" of its
# statistics, lancer's the "render" phase of --stats: neither counts
# parsing, set-up or output. Each ratio is the median of the runs' own
# ratios (its two sides ran a moment apart, so the shared machine's slow
# spells cancel), each time a median. Prints a Markdown table; with
# RESULTS, appends "frame" (POV-Ray / lancer at equal threads) and
# "scaling" (lancer's one thread / two threads) lines to it
# (scripts/bench-table.sh). Not a test: it asserts nothing.
#
#   sh scripts/bench-pov.sh [LANCER] [RUNS] [SCALE] [RESULTS]
#
# LANCER defaults to build/lancer, RUNS to 5, SCALE to 2.
set -eu
LANCER=${1:-build/lancer}
RUNS=${2:-5}
SCALE=${3:-2}
RESULTS=${4:-/dev/null}
WORK=build/bench-pov
mkdir -p "$WORK"
command -v povray >/dev/null || { echo "bench-pov: povray is not installed (scripts/deps.sh test)" >&2; exit 1; }

median() { sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }
col() { awk "{print $1}" "$WORK/$name.runs" | median; }

pov_s() { # threads: POV-Ray's trace time, in seconds
    povray -D -V -A "+W$((w * k))" "+H$((h * k))" "+WT$1" +FE "+O$WORK/pov.exr" "+I$WORK/$name.pov" \
        >"$WORK/pov.log" 2>&1
    sed -n 's/.*Trace Time:.*(\([0-9.]*\) seconds).*/\1/p' "$WORK/pov.log"
}
lancer_s() { # threads: lancer's render phase, in seconds
    "$LANCER" render "$scn" ${frame:+--frame "$frame"} --width "$w" --height "$h" --threads "$1" -q \
        -o "$WORK/lancer.exr" --stats "$WORK/stats.json"
    sed -n 's/.*"phases_s": {[^}]*"render": \([0-9.]*\).*/\1/p' "$WORK/stats.json"
}

# Each scene's export and size first; then RUNS rounds, each running every
# scene once: a slow spell of the machine (they last seconds) then lands
# on one run of a few scenes, which the medians drop, where one scene's
# runs back to back could all fall in it.
scenes=""
for scn in scenes/parity/*.scn; do
    name=$(basename "$scn" .scn)
    frame=$(sed -n 's/^# parity-frame: \([0-9]*\)$/\1/p' "$scn")
    segs=$(sed -n 's/^# parity-pn-segments: \([0-9]*\)$/\1/p' "$scn")
    read -r w h k <<SIZE
$("$LANCER" export-pov "$scn" ${frame:+--frame "$frame"} -o - | sed -n 's|^// lancer-reference: width \([0-9]*\) height \([0-9]*\) spp \([0-9]*\)$|\1 \2 \3|p')
SIZE
    w=$((w * SCALE))
    h=$((h * SCALE))
    "$LANCER" export-pov "$scn" ${frame:+--frame "$frame"} ${segs:+--pn-segments "$segs"} -o "$WORK/$name.pov" \
        --width "$w" --height "$h"
    echo "$w $h $k $frame" >"$WORK/$name.size"
    : >"$WORK/$name.runs"
    scenes="$scenes $scn"
done
for _ in $(seq "$RUNS"); do
    for scn in $scenes; do
        name=$(basename "$scn" .scn)
        read -r w h k frame <"$WORK/$name.size"
        echo "$(pov_s 1) $(lancer_s 1) $(pov_s 2) $(lancer_s 2)" >>"$WORK/$name.runs"
    done
done

echo "| scene | size | POV-Ray, 1 thread (s) | lancer, 1 (s) | POV-Ray, 2 (s) | lancer, 2 (s) | POV-Ray / lancer, 1 thread | at 2 threads | lancer 1 / 2 threads |"
echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"
for scn in $scenes; do
    name=$(basename "$scn" .scn)
    read -r w h k frame <"$WORK/$name.size"
    r1=$(col '$1 / $2')
    r2=$(col '$3 / $4')
    sc=$(col '$2 / $4')
    printf '| %s | %s | %.3f | %.3f | %.3f | %.3f | %.2f | %.2f | %.2f |\n' "$name" \
        "${w}x$h$([ "$k" -gt 1 ] && echo " (${k}x$k spp)")" "$(col '$1')" "$(col '$2')" "$(col '$3')" "$(col '$4')" \
        "$r1" "$r2" "$sc"
    printf 'frame\t%s, 1 thread\t%.3f\nframe\t%s, 2 threads\t%.3f\nscaling\t%s\t%.3f\n' "$name" "$r1" "$name" "$r2" \
        "$name" "$sc" >>"$RESULTS"
done
