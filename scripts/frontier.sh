#!/bin/sh
# Time against error: sweeps the render knobs that trade one for the other
# (spp, trace depth, adc_bailout, classic or robust intersection, PN mode,
# area light samples, and adaptive anti-aliasing, adaptive area lights and
# the --quality presets where `lancer render --help` offers them) on a set
# of benchmark scenes, and plots each scene's Pareto front.
#
#   sh scripts/frontier.sh [LANCER]      (`make frontier` builds and runs it)
#
# Every scene is rendered at a reduced size. A setting is the scene's own
# ("base") with one knob changed, or one of a few combined points (the
# proposed draft/preview/final presets among them). Its time is the median,
# over FRONTIER_RUNS runs (default 3; each a pass over all of a scene's
# settings), of the render phase that --stats reports (parsing and the BVH
# build do not depend on the knobs); its error is
# `lancer diff` against the scene's reference:
#   POV-Ray rendering lancer's export of the scene at FRONTIER_REF_K times
#   the size (default 13; 11 for the area-light scene), averaged down (diff
#   --downsample), with max_trace_level 24, adc_bailout 0, every area light
#   a full 16 x 16 grid and PN patches tessellated at 128 segments an edge;
#   cached like scripts/parity.sh's references in $LANCER_POV_CACHE;
#   or, where POV-Ray is missing or fails, lancer at its most accurate
#   (spp = that factor, at most 16; depth 24, adc_bailout 0, robust, exact
#   PN, 16 x 16 area grids).
# Writes build/frontier/frontier.csv
#   scene,settings,seconds,rms,max,psnr,pixels_over_2e-3
# build/frontier/references.txt (each scene's reference, and how far lancer
# at those accurate settings is from it), build/frontier/front.txt (each
# scene's Pareto front) and one plot per scene, docs/frontier/SCENE.png.
# FRONTIER_OUT and FRONTIER_PLOTS move those; FRONTIER_PLOT_ONLY=1 only
# draws the plots again. A whole run takes 6 to 7 minutes on 2 cores
# (POV-Ray references included; about 2 of them when none is cached).
set -eu

LANCER=${1:-build/lancer}
OUT=${FRONTIER_OUT:-build/frontier}
PLOTS=${FRONTIER_PLOTS:-docs/frontier}
RUNS=${FRONTIER_RUNS:-3}
REF_K=${FRONTIER_REF_K:-13}
REF_DEPTH=24
REF_AREA=16
REF_PN_SEGMENTS=128
CACHE=${LANCER_POV_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/lancer/pov}

# name, scene file, width, height, reference factor (0: FRONTIER_REF_K).
# The area-light scene's reference, 16 x 16 shadow rays per light and
# sample, is made at 11 times the size: 13 times would take POV-Ray minutes.
# Both factors are primes above every spp swept, so that no spp's grid is
# a sub-grid of the reference's (which would flatter it).
SCENES="default scenes/default.scn 160 120 0
depth6 scenes/parity/depth6.scn 160 120 0
bunny scenes/parity/bunny.scn 144 144 0
pn scenes/parity/pn.scn 160 120 0
glass scenes/parity/glass.scn 160 120 0
area scenes/parity/area.scn 160 120 11"

# The knobs' values, each swept alone from the scene's own setting.
SPP_LIST="2 3 4 5 6 7 8"
DEPTH_LIST="1 2 3 4 6 8 12 16"
ADC_LIST="0 0.001 0.004 0.016 0.0625 0.25"
AREA_LIST="1 2 3 4 6 8"
ADAPTIVE_LIST="0 1 2"
AA_LIST="spp3+aa0.1 spp4+aa0.1 spp4+aa0.03 spp4+aa0.01 spp7+aa0.1 spp7+aa0.03 spp7+aa0.01"
# The draft/preview/final presets proposed from these fronts (what
# `lancer render --quality` is to set; its own presets are swept too where
# it has them), and a few other combined points, among them a costlier
# final (spp7). A label's knobs are split at "+".
PRESETS="draft=spp1+adc0.016+area4+adaptive0
preview=spp3+aa0.1+adc0.004+area8+adaptive0
final=spp4+aa0.03+area8+adaptive1"
COMBOS="spp4+adc0.016 spp4+depth12+adc0 spp2+adc0.004+area4+adaptive0
spp3+aa0.1+adc0.004+area8+adaptive1 spp4+aa0.1+adc0.004+area8+adaptive1
spp5+aa0.03+area8+adaptive1 spp6+aa0.03+area8+adaptive1 spp7+aa0.03+area8+adaptive1
spp8+aa0.03+area8+adaptive1"

die() { echo "frontier: $*" >&2; exit 1; }
[ -x "$LANCER" ] || die "$LANCER is not built (make)"
command -v gnuplot >/dev/null || die "gnuplot is not installed (scripts/deps.sh bench)"
mkdir -p "$OUT" "$PLOTS" "$CACHE"

# Others may rebuild build/lancer while this runs: the sweep runs a copy of
# it, taken once it answers (not while the linker writes it).
tries=0
until cp "$LANCER" "$OUT/lancer.tmp" 2>/dev/null && "$OUT/lancer.tmp" --version >/dev/null 2>&1; do
    tries=$((tries + 1))
    [ "$tries" -lt 30 ] || die "$LANCER does not run"
    sleep 2
done
mv "$OUT/lancer.tmp" "$OUT/lancer"
LANCER=$OUT/lancer

help=$("$LANCER" render --help 2>&1)
has() {
    case $help in *"$1 "*) return 0 ;; esac
    return 1
}

# knob_args LABEL: the render options that a label such as spp4+adc0.016 names
knob_args() {
    args=""
    for knob in $(echo "$1" | tr '+' ' '); do
        case $knob in
            base) ;;
            spp*) args="$args --spp ${knob#spp}" ;;
            depth*) args="$args --max-depth ${knob#depth}" ;;
            adc*) args="$args --adc-bailout ${knob#adc}" ;;
            classic) args="$args --classic" ;;
            area*) args="$args --area-samples ${knob#area}" ;;
            adaptive*) args="$args --area-adaptive ${knob#adaptive}" ;;
            aa*) args="$args --aa-threshold ${knob#aa}" ;;
            quality-*) args="$args --quality ${knob#quality-}" ;;
            *) die "unknown knob $knob" ;;
        esac
    done
    echo "$args"
}

# render_once SCN W H OUT.exr KNOBS: renders once, prints the render phase
# in seconds
render_once() {
    scn=$1 w=$2 h=$3 img=$4
    args=$(knob_args "$5") || return 1
    # shellcheck disable=SC2086
    set -- $args
    "$LANCER" render "$scn" --width "$w" --height "$h" "$@" -o "$img" --float -q \
        --stats "$img.json" </dev/null || return 1
    sed -n 's/.*"phases_s": {[^}]*"render": \([0-9.eE+-]*\).*/\1/p' "$img.json"
}

# reference NAME SCN W H K: makes the reference image; sets ref, refdown, refname
reference() {
    name=$1 scn=$2 w=$3 h=$4 k=$5
    if command -v povray >/dev/null; then
        pov="$OUT/$name/ref.pov"
        segs=""
        grep -q '"pn_patches": {"exact": 0, "fast": 0}' "$OUT/$name/base.exr.json" || segs=$REF_PN_SEGMENTS
        if "$LANCER" export-pov "$scn" --width "$w" --height "$h" ${segs:+--pn-segments "$segs"} -o "$pov.tmp" </dev/null; then
            sed -e "s/^  max_trace_level [0-9]*\$/  max_trace_level $REF_DEPTH/" \
                -e 's/^  adc_bailout .*/  adc_bailout 0/' \
                -e "s/^\\(  area_light <[^>]*>, <[^>]*>\\), [0-9]*, [0-9]*\$/\\1, $REF_AREA, $REF_AREA/" \
                -e '/^  adaptive [0-9]*$/d' "$pov.tmp" >"$pov"
            rm -f "$pov.tmp"
            grep -q "^  max_trace_level $REF_DEPTH\$" "$pov" ||
                echo "frontier: $name: warning: the reference keeps the scene's max_trace_level" >&2
            povargs="-D -V -GA +GF +GW -A +W$((w * k)) +H$((h * k)) +FE"
            key=$( (cat "$pov"; echo "$povargs") | sha256sum | cut -c1-20)
            ref="$CACHE/frontier-$name-$key.exr"
            if [ ! -s "$ref" ]; then
                tmp="$CACHE/.frontier-$name-$key.$$.exr"
                echo "frontier: $name: POV-Ray reference, $((w * k))x$((h * k))" >&2
                # shellcheck disable=SC2086
                if ! povray $povargs "+O$tmp" "+I$pov" </dev/null 2>"$OUT/$name/povray.log" || [ ! -s "$tmp" ]; then
                    echo "frontier: $name: POV-Ray failed (see $OUT/$name/povray.log); lancer's reference instead" >&2
                    rm -f "$tmp"
                else
                    mv "$tmp" "$ref"
                fi
            fi
            if [ -s "$ref" ]; then
                refdown=$k
                refshort="POV-Ray, ${k}x${k} supersampled"
                refname="POV-Ray 3.7, ${k}x${k} supersampled (render at $((w * k))x$((h * k)), averaged down), max_trace_level $REF_DEPTH, adc_bailout 0, area lights ${REF_AREA}x$REF_AREA${segs:+, PN patches tessellated at $segs segments}"
                return 0
            fi
        fi
    fi
    ref="$OUT/$name/ref-lancer.exr"
    refdown=1
    refshort="lancer, spp $k"
    refname="lancer, spp $k, max-depth $REF_DEPTH, adc-bailout 0, robust, pn-mode exact, area-samples $REF_AREA"
    echo "frontier: $name: lancer reference" >&2
    "$LANCER" render "$scn" --width "$w" --height "$h" --spp "$k" --max-depth "$REF_DEPTH" \
        --adc-bailout 0 --pn-mode exact --area-samples "$REF_AREA" -o "$ref" --float -q </dev/null
}

# error IMG: "rms,max,psnr,over" of IMG against the reference
error() {
    line=$("$LANCER" diff "$1" "$ref" --downsample "$refdown" </dev/null) || return 1
    echo "$line" | sed -n 's/^max=\([^ ]*\) mean=[^ ]* rms=\([^ ]*\) psnr=\([^ ]*\) over=\([0-9]*\) .*/\2,\1,\3,\4/p'
}

csv="$OUT/frontier.csv"
start=$(date +%s)
# FRONTIER_PLOT_ONLY=1 draws the plots again from the last frontier.csv.
if [ "${FRONTIER_PLOT_ONLY:-0}" != 1 ]; then
    echo "scene,settings,seconds,rms,max,psnr,pixels_over_2e-3" >"$csv.tmp"
    : >"$OUT/references.txt.tmp"

    while read -r name scn w h k; do
        [ "$k" -gt 0 ] || k=$REF_K
        [ -r "$scn" ] || die "$scn is missing"
        mkdir -p "$OUT/$name"
        rm -f "$OUT/$name"/*.exr "$OUT/$name"/*.json "$OUT/$name"/*.times
        # One untimed run first, which warms the caches; its plan says which
        # knobs matter here.
        plan="$OUT/$name/base.exr.json"
        render_once "$scn" "$w" "$h" "$OUT/$name/base.exr" base >/dev/null || die "$name: render failed"
        reference "$name" "$scn" "$w" "$h" "$k" || die "$name: no reference"
        labels=""
        for v in $SPP_LIST; do labels="$labels spp$v"; done
        if grep -q '"reflective": true\|"transparent": true' "$plan"; then
            depth=$(sed -n 's/.*"max_depth": \([0-9]*\).*/\1/p' "$plan")
            for v in $DEPTH_LIST; do [ "$v" = "$depth" ] || labels="$labels depth$v"; done
            for v in $ADC_LIST; do labels="$labels adc$v"; done
        fi
        labels="$labels classic" # (PN patches: Newton's steps; the robust variant traces them exact)
        if grep -q '"samples": \([2-9]\|[1-9][0-9]\)' "$plan"; then
            if has --area-samples; then
                for v in $AREA_LIST; do labels="$labels area$v"; done
            fi
            if has --area-adaptive; then
                for v in $ADAPTIVE_LIST; do labels="$labels adaptive$v area8+adaptive$v"; done
            fi
        fi
        if has --aa-threshold; then
            labels="$labels $AA_LIST"
        fi
        labels="$labels $COMBOS"
        # lancer's own presets, where it has them, beside the proposed ones
        if has --quality; then
            labels="$labels quality-draft quality-preview quality-final"
        fi
        for p in $PRESETS; do labels="$labels ${p%%=*}"; done
        # The accurate lancer settings, run once (not a point of the sweep):
        # how far they are from the reference says how good the reference is.
        floor=""
        if [ "$refdown" -gt 1 ]; then
            "$LANCER" render "$scn" --width "$w" --height "$h" --spp "$k" --max-depth "$REF_DEPTH" \
                --adc-bailout 0 --pn-mode exact --area-samples "$REF_AREA" -o "$OUT/$name/accurate.exr" \
                --float -q </dev/null || die "$name: render failed"
            floor=$(error "$OUT/$name/accurate.exr") || die "$name: diff failed"
        fi
        echo "$w $h $refshort" >"$OUT/$name/reference"
        {
            echo "$name ($scn at ${w}x$h): $refname"
            [ -z "$floor" ] || echo "    lancer at those settings (spp $k) against it: rms,max,psnr,over = $floor"
        } >>"$OUT/references.txt.tmp"

        # label and knobs of each setting
        : >"$OUT/$name/settings"
        for label in base $labels; do
            knobs=$label
            for p in $PRESETS; do [ "${p%%=*}" = "$label" ] && knobs=${p#*=}; done
            # an spp of the reference's factor or above would not be measured
            spp=$(echo "$knobs" | sed -n 's/.*spp\([0-9]*\).*/\1/p')
            [ -z "$spp" ] || [ "$spp" -lt "$k" ] || continue
            echo "$label $knobs" >>"$OUT/$name/settings"
        done
        # FRONTIER_RUNS passes over all the settings, so that a burst of load
        # from elsewhere slows one run of several settings, not every run of one
        pass=0
        while [ "$pass" -lt "$RUNS" ]; do
            while read -r label knobs; do
                render_once "$scn" "$w" "$h" "$OUT/$name/$label.exr" "$knobs" \
                    >>"$OUT/$name/$label.times" || die "$name $label: render failed"
            done <"$OUT/$name/settings"
            pass=$((pass + 1))
        done
        while read -r label knobs; do
            t=$(sort -g "$OUT/$name/$label.times" | sed -n "$(((RUNS + 1) / 2))p")
            e=$(error "$OUT/$name/$label.exr") || die "$name $label: diff failed"
            [ "$label" = "$knobs" ] || label="$label($knobs)"
            echo "$name,$label,$t,$e" >>"$csv.tmp"
            echo "frontier: $name $label ${t}s $e" >&2
        done <"$OUT/$name/settings"
    done <<EOF
$SCENES
EOF
    mv "$csv.tmp" "$csv"
    mv "$OUT/references.txt.tmp" "$OUT/references.txt"
fi

: >"$OUT/front.txt.tmp"
# The Pareto front of each scene: the settings that no other setting beats
# in both time and rms (ties in time go to the smaller error).
for name in $(echo "$SCENES" | cut -d' ' -f1); do
    dat="$OUT/$name/points.dat"
    front="$OUT/$name/front.dat"
    # time, rms (a zero is drawn at 1e-7 on the log axis), short label
    awk -F, -v s="$name" '$1 == s {
            lab = $2; sub(/\(.*/, "", lab); gsub(/depth/, "d", lab); gsub(/adaptive/, "ad", lab)
            gsub(/classic/, "cl", lab); gsub(/spp/, "s", lab); gsub(/area/, "A", lab); sub(/^quality-/, "q-", lab)
            r = $4 + 0; if (r <= 0) r = 1e-7
            printf "%s %s %s\n", $3, r, lab }' "$csv" | sort -k1,1g -k2,2g >"$dat"
    awk 'BEGIN { best = -1 } best < 0 || $2 < best { print; best = $2 }' "$dat" >"$front"
    {
        printf '%s:' "$name"
        awk '{ printf " %s (%ss, rms %s)", $3, $1, $2 }' "$front"
        echo
    } >>"$OUT/front.txt.tmp"
    read -r w h refshort <"$OUT/$name/reference"
    # room on the right and above for the labels
    range=$(awk 'NR == 1 { x0 = x1 = $1; y0 = y1 = $2 }
        { if ($1 < x0) x0 = $1; if ($1 > x1) x1 = $1; if ($2 < y0) y0 = $2; if ($2 > y1) y1 = $2 }
        END { printf "set xrange [%g:%g]; set yrange [%g:%g]", x0 / 1.5, x1 * 4, y0 / 1.6, y1 * 1.6 }' "$dat")
    term="pngcairo size 640,480 font 'sans,9'"
    gnuplot -e 'set terminal pngcairo' 2>/dev/null || term="png size 640,480 small"
    gnuplot <<EOF
set terminal $term
set output '$PLOTS/$name.png'
set title "lancer, $name at ${w}x$h: time against rms error (reference: $refshort)"
set logscale xy
$range
set xtics ("0.001" 0.001, "0.002" 0.002, "0.005" 0.005, "0.01" 0.01, "0.02" 0.02, "0.05" 0.05, \
    "0.1" 0.1, "0.2" 0.2, "0.5" 0.5, "1" 1, "2" 2, "5" 5, "10" 10, "20" 20, "50" 50, "100" 100)
set ytics ("1e-5" 1e-5, "2e-5" 2e-5, "5e-5" 5e-5, "1e-4" 1e-4, "2e-4" 2e-4, "5e-4" 5e-4, \
    "0.001" 0.001, "0.002" 0.002, "0.005" 0.005, "0.01" 0.01, "0.02" 0.02, "0.05" 0.05, \
    "0.1" 0.1, "0.2" 0.2, "0.5" 0.5, "1" 1)
set xlabel "render time, s (median of $RUNS)"
set ylabel "rms error against the reference"
set grid
set key bottom left
preset(s) = s eq "draft" || s eq "preview" || s eq "final" || s eq "q-draft" || s eq "q-preview" || s eq "q-final"
plot '$dat' using 1:2 with points pt 7 ps 0.6 lc rgb "#4477aa" title "setting", \
     '$dat' using 1:2:3 with labels offset 0.4,0.45 left font ",7" notitle, \
     '$front' using 1:2 with linespoints lw 1.5 pt 6 ps 1.6 lc rgb "#cc3311" title "Pareto front", \
     '$dat' using 1:(preset(strcol(3)) ? \$2 : 1/0) \
         with points pt 13 ps 1.4 lc rgb "#228833" title "presets"
EOF
done
mv "$OUT/front.txt.tmp" "$OUT/front.txt"
echo "frontier: $(($(wc -l <"$csv") - 1)) settings in $(($(date +%s) - start)) s: $csv, $OUT/references.txt, $OUT/front.txt, $PLOTS/*.png" >&2
