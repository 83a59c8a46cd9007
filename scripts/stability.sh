#!/bin/sh
# Stability: renders each scene of scenes/stability/ at unit scale, scaled
# by 1e-4 and by 1e5, and translated by 1e5 (render --scale/--translate move
# the whole scene, camera and lights included), and compares each with the
# unit-scale render by the parity rule: at most 0.1% of pixels over 2e-3.
# The robust defaults must pass; the classic routines are rendered the same
# way and only reported, to show where they fail.
#
#   sh scripts/stability.sh [LANCER]
#
# Prints one line per scene, transform and variant, then
# "stability: N passed, N failed" (robust renders only).
set -u
LANCER=${1:-build/lancer}
WORK=${LANCER_STABILITY_OUT:-build/stability}
mkdir -p "$WORK"
pass=0
fail=0
for scn in scenes/stability/*.scn; do
    name=$(basename "$scn" .scn)
    for variant in robust classic; do
        flag=""
        [ "$variant" = classic ] && flag=--classic
        ref="$WORK/$name-$variant-unit.exr"
        "$LANCER" render "$scn" -o "$ref" --float -q $flag || { fail=$((fail + 1)); continue; }
        for t in "scale 1e-4" "scale 1e5" "translate 1e5,1e5,1e5"; do
            set -- $t
            out="$WORK/$name-$variant-$1-$2.exr"
            if ! "$LANCER" render "$scn" -o "$out" --float -q $flag "--$1" "$2"; then
                echo "stability: $name $variant --$1 $2 FAIL (render)"
                [ "$variant" = robust ] && fail=$((fail + 1))
                continue
            fi
            line=$("$LANCER" diff "$ref" "$out" --heatmap "$WORK/$name-$variant-$1-$2-heat.png")
            over=$(echo "$line" | sed -n 's/.* over=\([0-9]*\) .*/\1/p')
            pixels=$(echo "$line" | sed -n 's/.* pixels=\([0-9]*\)$/\1/p')
            if [ "$over" -le $((pixels / 1000)) ]; then verdict=PASS; else verdict=FAIL; fi
            if [ "$variant" = robust ]; then
                if [ $verdict = PASS ]; then pass=$((pass + 1)); else fail=$((fail + 1)); fi
            else
                verdict="($verdict, measured only)"
            fi
            echo "stability: $name $variant --$1 $2 $line $verdict"
        done
    done
done
echo "stability: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
