#!/bin/sh
# Stability: moving a whole scene (render --scale S / --translate X,Y,Z move
# it, camera and lights included) must not change its picture. Each check
# renders a scene moved and compares it with the same scene's unmoved render
# (same routines, size and spp) by the parity rule: at most 0.1% of the
# pixels (pixels/1000, by integer division) may differ by more than 2e-3 in
# some channel (`lancer diff`'s over=). What is checked:
#
#   scenes/stability/*.scn (contact.scn): every coordinate is a multiple of
#     1/64, so that translating by 1e5 moves the scene exactly in float.
#     Scaled by 1e-4, scaled by 1e5 and translated by 1e5,1e5,1e5, each by
#     the parity rule; and the render translated by 1e5,1e5,1e5 must be
#     identical to the unit one: every channel of every pixel equal
#     (`lancer diff` max=0; the files differ in the stamp of their headers,
#     which records the move).
#   scenes/parity/*.scn (the list scripts/parity.sh uses, at the size and
#     spp of each scene file, as parity.sh renders them): translated by
#     1e5,1e5,1e5, by -312345.6,20987.3,700001.7 and by 1e7,1e7,1e7, none of
#     which moves the scene exactly in float, each by the parity rule.
#     bunny.scn needs `make cgal-data`, as in parity.sh.
#
# Both sets are rendered with the robust routines (the default), which must
# pass, and with the classic ones (--classic), which are only reported
# ("measured only", a failed render included), to show where they fail; the
# bit-identity check is for the robust routines only. A robust render or
# diff that fails is a failure. Renders (--float), a heat map of each diff
# and each render's stderr (.log) go to $LANCER_STABILITY_OUT, default
# build/stability.
#
#   sh scripts/stability.sh [LANCER]
#
# Prints one line per scene, move and routines (the diff figures and the
# verdict), one more per bit-identity check, then "stability: N passed, N
# failed" (robust checks only); exits non-zero if any failed.
set -u
LANCER=${1:-build/lancer}
WORK=${LANCER_STABILITY_OUT:-build/stability}
mkdir -p "$WORK"
pass=0
fail=0

# tally VARIANT PASS|FAIL [WHY]: counts a robust verdict; a classic one is
# measured only. Sets shown, the verdict as printed.
tally() {
    if [ "$1" = robust ]; then
        if [ "$2" = PASS ]; then pass=$((pass + 1)); else fail=$((fail + 1)); fi
        shown="$2${3:+ ($3)}"
    else
        shown="($2, measured only${3:+; $3})"
    fi
}

# render SCENE OUT VARIANT [MOVE...]: renders SCENE to OUT, stderr to its .log
render() {
    cl=""
    [ "$3" = classic ] && cl=--classic
    r_scn=$1
    r_out=$2
    shift 3
    "$LANCER" render "$r_scn" -o "$r_out" --float -q ${cl:+"$cl"} "$@" 2>"${r_out%.exr}.log"
}

# unit SCENE NAME VARIANT: renders the unmoved reference; non-zero if it fails
unit() {
    ref="$WORK/$2-$3-unit.exr"
    render "$1" "$ref" "$3" && return 0
    tally "$3" FAIL "render: $(tail -n 1 "${ref%.exr}.log")"
    echo "stability: $2 $3 unit $shown"
    return 1
}

# move SCENE NAME VARIANT OPTION VALUE: renders SCENE moved by --OPTION VALUE
# and compares it with the unit render by the parity rule. Non-zero if
# nothing was rendered.
move() {
    label="$2 $3 --$4 $5"
    out="$WORK/$2-$3-$4-$5.exr"
    if ! render "$1" "$out" "$3" "--$4" "$5"; then
        tally "$3" FAIL "render: $(tail -n 1 "${out%.exr}.log")"
        echo "stability: $label $shown"
        return 1
    fi
    if ! line=$("$LANCER" diff "$WORK/$2-$3-unit.exr" "$out" --heatmap "${out%.exr}-heat.png"); then
        tally "$3" FAIL diff
        echo "stability: $label $shown"
        return 0
    fi
    over=$(echo "$line" | sed -n 's/.* over=\([0-9]*\) .*/\1/p')
    pixels=$(echo "$line" | sed -n 's/.* pixels=\([0-9]*\)$/\1/p')
    allowed=$((${pixels:-0} / 1000))
    if [ -n "$over" ] && [ "$over" -le "$allowed" ]; then
        tally "$3" PASS
    else
        tally "$3" FAIL
    fi
    echo "stability: $label $line allowed=$allowed $shown"
}

# identical NAME VARIANT OPTION VALUE: the moved render must equal the unit
# render, every channel of every pixel
identical() {
    label="$1 $2 --$3 $4"
    line=$("$LANCER" diff "$WORK/$1-$2-unit.exr" "$WORK/$1-$2-$3-$4.exr" 2>&1)
    case $line in
    "max=0 mean=0 "*) tally "$2" PASS ;;
    *) tally "$2" FAIL "$line" ;;
    esac
    echo "stability: $label identical to unit $shown"
}

for scn in scenes/stability/*.scn; do
    name=$(basename "$scn" .scn)
    for variant in robust classic; do
        unit "$scn" "$name" "$variant" || continue
        for t in "scale 1e-4" "scale 1e5" "translate 1e5,1e5,1e5"; do
            if move "$scn" "$name" "$variant" "${t%% *}" "${t#* }" &&
                [ "$variant" = robust ] && [ "$t" = "translate 1e5,1e5,1e5" ]; then
                identical "$name" "$variant" translate 1e5,1e5,1e5
            fi
        done
    done
done

for scn in scenes/parity/*.scn; do
    name=$(basename "$scn" .scn)
    for variant in robust classic; do
        unit "$scn" "$name" "$variant" || continue
        for t in 1e5,1e5,1e5 -312345.6,20987.3,700001.7 1e7,1e7,1e7; do
            move "$scn" "$name" "$variant" translate "$t"
        done
    done
done

echo "stability: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
