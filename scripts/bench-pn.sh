#!/bin/sh
# Time against error for PN triangles: each mesh's PN surface rendered in
# exact mode (the reference), in fast mode (Newton's steps, which only the
# classic variant takes: the robust one traces every patch exact), as flat
# triangles, and as the tessellation that export-pov writes at n segments
# an edge, at 1024 x 1024 on one thread. For each: the BVH build time, the
# render time, the peak memory, and the image error against the exact
# render. Writes docs/pn-time-error.csv and, when gnuplot is installed,
# docs/pn-time-error.svg. With RESULTS, appends the PN targets' ratios to
# it (scripts/bench-table.sh): "pn-exact", exact over flat render time
# (bunny00, the median of five pairs rendered in turns); "pn-memory", PN
# over flat peak memory; "pn-fast", the time (build and render) of the
# first tessellation whose error is at most fast mode's over fast mode's,
# "inf" when none of those tried reaches it; "pn-tess-memory", PN's peak
# memory over that tessellation's (or the finest tried, which has more
# error).
#
#   sh scripts/bench-pn.sh [LANCER] [PN_TESS] [RESULTS]
#
# LANCER defaults to build/lancer, PN_TESS (tests/bench/pn_tess.c) to
# build/pn_tess; the meshes come from build/cgal-data (make cgal-data).
set -eu
LANCER=${1:-build/lancer}
TESS=${2:-build/pn_tess}
RESULTS=${3:-/dev/null}
WORK=build/bench-pn
CSV=docs/pn-time-error.csv
MESHES=build/cgal-data/meshes
mkdir -p "$WORK"
for x in "$LANCER" "$TESS"; do
    [ -x "$x" ] || { echo "bench-pn: $x is missing (make bench builds it)" >&2; exit 1; }
done

# mesh: the tessellations to try (the larger stop where memory would)
plan="bunny00.off:1 2 4 8
eight.off:1 2 4 8 16 32"

# A scene framing the OFF mesh $1 (its bounding box, from its vertex lines)
# with the mesh statement $2, into $3.
scene() {
    awk -v stmt="$2" 'NR == 1 { next }
        /^[ \t]*#/ || NF == 0 { next }
        nv == "" { nv = $1; next }
        seen < nv { for (k = 1; k <= 3; k++) { if (seen == 0 || $k < lo[k]) lo[k] = $k; if (seen == 0 || $k > hi[k]) hi[k] = $k }; seen++; next }
        END {
            for (k = 1; k <= 3; k++) c[k] = (lo[k] + hi[k]) / 2
            s = hi[1] - lo[1]; if (hi[2] - lo[2] > s) s = hi[2] - lo[2]; if (hi[3] - lo[3] > s) s = hi[3] - lo[3]
            printf "image { width 1024 height 1024 background 0.2 0.25 0.3 max_depth 2 }\n"
            printf "camera { eye %.9g %.9g %.9g target %.9g %.9g %.9g fov 34 }\n", c[1] + 0.3 * s, c[2] + 0.5 * s, c[3] - 2.2 * s, c[1], c[2], c[3]
            printf "light { position %.9g %.9g %.9g }\n", c[1] - 2 * s, c[2] + 3 * s, c[3] - 2 * s
            printf "material m { color 0.8 0.7 0.6 diffuse 0.7 phong 0.5 phong_size 40 }\n"
            print stmt
        }' "$1" >"$3"
}

# render NAME SCENE [OPTION]: one thread, float EXR; prints "build render rss_mb"
render() {
    /usr/bin/time -f "%M" -o "$WORK/$1.rss" "$LANCER" render "$2" -o "$WORK/$1.exr" --float --threads 1 \
        --stats "$WORK/$1.json" -q ${3:+"$3"}
    b=$(sed -n 's/.*"phases_s": {[^}]*"build": \([0-9.]*\).*/\1/p' "$WORK/$1.json")
    r=$(sed -n 's/.*"phases_s": {[^}]*"render": \([0-9.]*\).*/\1/p' "$WORK/$1.json")
    kb=$(tail -n 1 "$WORK/$1.rss")
    echo "$b $r $((kb / 1024))"
}

echo "mesh,variant,n,triangles,build_s,render_s,peak_mb,rms,mean,max,over" >"$CSV.tmp"
echo "$plan" | while IFS=: read -r mesh ns; do
    name=${mesh%.off}
    path=$(cd "$MESHES" && pwd)/$mesh
    [ -f "$path" ] || { echo "bench-pn: $path is missing (make cgal-data)" >&2; exit 1; }
    tris=$(awk 'NR == 1 { next } /^[ \t]*#/ || NF == 0 { next } { print $2; exit }' "$path")
    for v in exact fast flat $ns; do
        case $v in
            exact | fast) stmt="mesh { file \"$path\" pn pn_mode $v material m }"; n=0; t=$tris ;;
            flat) stmt="mesh { file \"$path\" flat material m }"; n=0; t=$tris ;;
            *)
                n=$v
                "$TESS" "$path" "$n" "$WORK/$name-$n.off"
                stmt="mesh { file \"$(pwd)/$WORK/$name-$n.off\" smooth material m }"
                t=$((tris * n * n))
                v=tessellated
                ;;
        esac
        scene "$path" "$stmt" "$WORK/$name-$v-$n.scn"
        set -- $(render "$name-$v-$n" "$WORK/$name-$v-$n.scn" $([ "$v" = fast ] && echo --classic))
        if [ "$v" = exact ]; then
            err="0 0 0 0"
        else
            line=$("$LANCER" diff "$WORK/$name-exact-0.exr" "$WORK/$name-$v-$n.exr")
            err=$(echo "$line" | sed -n 's/^max=\([^ ]*\) mean=\([^ ]*\) rms=\([^ ]*\) .* over=\([0-9]*\) .*/\3 \2 \1 \4/p')
        fi
        [ "$v" = tessellated ] && rm -f "$WORK/$name-$n.off"
        # shellcheck disable=SC2086
        set -- "$@" $err
        echo "$name,$v,$n,$t,$1,$2,$3,$4,$5,$6,$7" | tee -a "$CSV.tmp"
    done
done
mv "$CSV.tmp" "$CSV"

# The targets, mesh by mesh; the rows of a mesh come exact, fast, flat, then
# the tessellations by n.
awk -F, 'NR > 1 {
        m = $1
        if ($2 == "exact") { et[m] = $6; em[m] = $7; order[++nm] = m }
        else if ($2 == "fast") { ft[m] = $5 + $6; frms[m] = $8 }
        else if ($2 == "flat") { lt[m] = $6; lm[m] = $7 }
        else if (!(m in reach)) {
            tm[m] = $7
            if ($8 <= frms[m]) { reach[m] = ($5 + $6) / ft[m] }
        }
    }
    END {
        for (i = 1; i <= nm; i++) {
            m = order[i]
            printf "pn-memory\t%s\t%.3f\n", m, em[m] / lm[m]
            printf "pn-fast\t%s\t%s\n", m, (m in reach) ? sprintf("%.3f", reach[m]) : "inf"
            printf "pn-tess-memory\t%s\t%.3f\n", m, em[m] / tm[m]
        }
    }' "$CSV" >>"$RESULTS"

# pn-exact: bunny00's exact and flat renders in turns, PAIRS times, and the
# median of the pairs' ratios (one render of each moves by a fifth between
# runs on a shared machine).
PAIRS=5
: >"$WORK/pairs"
for _ in $(seq "$PAIRS"); do
    set -- $(render bunny00-exact-pair "$WORK/bunny00-exact-0.scn")
    e=$2
    set -- $(render bunny00-flat-pair "$WORK/bunny00-flat-0.scn")
    echo "$e $2" >>"$WORK/pairs"
done
ratio=$(awk '{print $1 / $2}' "$WORK/pairs" | sort -g |
    awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}')
echo "bunny00, exact / flat render time, $PAIRS pairs in turns (s s):" $(cat "$WORK/pairs") "median ratio $ratio"
printf "pn-exact\tbunny00\t%.3f\n" "$ratio" >>"$RESULTS"

if command -v gnuplot >/dev/null; then
    gnuplot <<EOF
set terminal svg size 900,520 font "sans,12"
set output "docs/pn-time-error.svg"
set datafile separator ","
set logscale xy
set xlabel "build + render time, one thread, 1024 x 1024 (s)"
set ylabel "RMS difference from the exact render"
set key top right
set title "PN surfaces: time against error"
plot for [m in "bunny00 eight"] "< awk -F, '\$1 == \"" . m . "\" && \$2 == \"tessellated\"' $CSV" \
        using (\$5 + \$6):8 with linespoints title m . ", tessellated (n = 1, 2, 4, ...)", \
     for [m in "bunny00 eight"] "< awk -F, '\$1 == \"" . m . "\" && \$2 == \"fast\"' $CSV" \
        using (\$5 + \$6):(\$8 > 0 ? \$8 : 1e-7) with points pointsize 2 title m . ", fast mode", \
     for [m in "bunny00 eight"] "< awk -F, '\$1 == \"" . m . "\" && \$2 == \"exact\"' $CSV" \
        using (\$5 + \$6):(1e-7) with points pointsize 2 pt 7 title m . ", exact mode (error 0, drawn at 1e-7)"
EOF
    echo "bench-pn: wrote $CSV and docs/pn-time-error.svg"
else
    echo "bench-pn: wrote $CSV (no gnuplot: no plot)"
fi
