#!/bin/sh
# The whole-frame benchmark (make bench): scenes/bunny.scn (CGAL's bunny00 on
# a floor, one light, one mirror) at 1024^2, rendered by POV-Ray on one
# thread and by lancer on one and on two threads, in turns, RUNS times.
# POV-Ray's time is the "Trace Time" of its statistics, lancer's the
# "render" phase of --stats: neither counts parsing, set-up or output.
# Each ratio is the median of the runs' own ratios (the two sides of a
# ratio ran a moment apart, so the shared machine's slow spells cancel),
# and every time is a median. With RESULTS, appends the "mirror" (POV-Ray /
# lancer) and "scaling" (one thread / two) lines to it
# (scripts/bench-table.sh). Not a test: it asserts nothing.
#
#   sh scripts/bench-frame.sh [LANCER] [RUNS] [RESULTS]
#
# LANCER defaults to build/lancer, RUNS to 9. Needs povray and the CGAL
# meshes (make cgal-data).
set -eu
LANCER=${1:-build/lancer}
RUNS=${2:-9}
RESULTS=${3:-/dev/null}
SCN=scenes/bunny.scn
WORK=build/bench-frame
mkdir -p "$WORK"
command -v povray >/dev/null || { echo "bench-frame: povray is not installed (scripts/deps.sh test)" >&2; exit 1; }
"$LANCER" export-pov "$SCN" -o "$WORK/bunny.pov"
read -r w h <<EOF
$(sed -n 's|^// lancer-reference: width \([0-9]*\) height \([0-9]*\) spp 1$|\1 \2|p' "$WORK/bunny.pov")
EOF

render_s() { # threads: lancer's render phase, in seconds
    "$LANCER" render "$SCN" --threads "$1" -q -o "$WORK/lancer.exr" --stats "$WORK/stats.json"
    sed -n 's/.*"phases_s": {[^}]*"render": \([0-9.]*\).*/\1/p' "$WORK/stats.json"
}

: >"$WORK/runs"
for _ in $(seq "$RUNS"); do
    povray -D -V -A "+W$w" "+H$h" +WT1 +FE "+O$WORK/pov.exr" "+I$WORK/bunny.pov" >"$WORK/pov.log" 2>&1
    p=$(sed -n 's/.*Trace Time:.*(\([0-9.]*\) seconds).*/\1/p' "$WORK/pov.log")
    echo "$p $(render_s 1) $(render_s 2)" >>"$WORK/runs"
done

median() { sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }
col() { awk "{print $1}" "$WORK/runs" | median; }
echo "| ${w}x$h, medians of $RUNS runs in turns | POV-Ray trace (s) | lancer, 1 thread (s) | lancer, 2 threads (s) | POV-Ray / lancer (1 thread) | 1 thread / 2 threads |"
echo "| --- | --- | --- | --- | --- | --- |"
printf '| %s | %.3f | %.3f | %.3f | %.2f | %.2f |\n' "$(basename "$SCN")" "$(col '$1')" "$(col '$2')" "$(col '$3')" \
    "$(col '$1 / $2')" "$(col '$2 / $3')"
printf 'mirror\tbunny.scn, 1 thread\t%.3f\nscaling\tbunny.scn, %sx%s\t%.3f\n' "$(col '$1 / $2')" "$w" "$h" "$(col '$2 / $3')" \
    >>"$RESULTS"
