#!/bin/sh
# POV-Ray parity: renders each scene with lancer and, from lancer's own
# export, with POV-Ray, and compares the two images.
#
#   sh scripts/parity.sh [LANCER] [SCENE.scn ...]
#
# LANCER defaults to build/lancer; the scenes to scenes/parity/*.scn.
# References are cached by a hash of the exported .pov file (and of the
# POV-Ray command line) in $LANCER_POV_CACHE, default ~/.cache/lancer/pov.
# A scene passes when at most 0.1% of its pixels differ by more than 2e-3 and
# 2^-11 of the value in some channel (half-float rounding). A scene that
# cannot meet that names the pixels and the reason in a line of its own,
# read here:
#     # parity-allow: N pixels: reason
# which allows N pixels over 2e-3 instead. A scene whose twin needs a finer
# tessellation of its PN patches says so in a line
#     # parity-pn-segments: N
# passed to export-pov as --pn-segments N. A scene with a camera path is
# compared at the frame a line
#     # parity-frame: N
# names (export-pov and render --frame N). Prints one line per scene, then
# "parity: N passed, N failed"; exits non-zero if any failed.
set -u
LANCER=${1:-build/lancer}
[ $# -gt 0 ] && shift
if [ $# -eq 0 ]; then set -- scenes/parity/*.scn; fi
CACHE=${LANCER_POV_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/lancer/pov}
WORK=${LANCER_PARITY_OUT:-build/parity}
mkdir -p "$CACHE" "$WORK"
command -v povray >/dev/null || { echo "parity: povray is not installed (scripts/deps.sh test)" >&2; exit 1; }

pass=0
fail=0
for scn in "$@"; do
    name=$(basename "$scn" .scn)
    pov="$WORK/$name.pov"
    segs=$(sed -n 's/^# parity-pn-segments: \([0-9]*\)$/\1/p' "$scn")
    frame=$(sed -n 's/^# parity-frame: \([0-9]*\)$/\1/p' "$scn")
    if ! "$LANCER" export-pov "$scn" ${segs:+--pn-segments "$segs"} ${frame:+--frame "$frame"} -o "$pov"; then
        echo "parity: $name FAIL (export)"
        fail=$((fail + 1))
        continue
    fi
    read -r w h k <<EOF
$(sed -n 's|^// lancer-reference: width \([0-9]*\) height \([0-9]*\) spp \([0-9]*\)$|\1 \2 \3|p' "$pov")
EOF
    povargs="-D -V -GA +GF +GW -A +W$((w * k)) +H$((h * k)) +FE"
    key=$( (cat "$pov"; echo "$povargs") | sha256sum | cut -c1-20)
    ref="$CACHE/$name-$key.exr"
    if [ ! -s "$ref" ]; then
        # povray resolves +I relative to its working directory
        tmp="$CACHE/.$name-$key.$$.exr"
        if ! povray $povargs "+O$tmp" "+I$pov" 2>"$WORK/$name.povlog" || [ ! -s "$tmp" ]; then
            echo "parity: $name FAIL (povray; see $WORK/$name.povlog)"
            rm -f "$tmp"
            fail=$((fail + 1))
            continue
        fi
        mv "$tmp" "$ref"
    fi
    out="$WORK/$name.exr"
    if ! "$LANCER" render "$scn" ${frame:+--frame "$frame"} -o "$out" --float -q; then
        echo "parity: $name FAIL (render)"
        fail=$((fail + 1))
        continue
    fi
    line=$("$LANCER" diff "$out" "$ref" --downsample "$k" --relative 4.8828125e-4 --heatmap "$WORK/$name-heat.png") || {
        echo "parity: $name FAIL (diff)"
        fail=$((fail + 1))
        continue
    }
    over=$(echo "$line" | sed -n 's/.* over=\([0-9]*\) .*/\1/p')
    pixels=$(echo "$line" | sed -n 's/.* pixels=\([0-9]*\)$/\1/p')
    allowed=$((pixels / 1000))
    allow=$(sed -n 's/^# parity-allow: \([0-9]*\) pixels: .*/\1/p' "$scn")
    [ -n "$allow" ] && allowed=$allow
    if [ "$over" -le "$allowed" ]; then
        verdict=PASS
        pass=$((pass + 1))
    else
        verdict=FAIL
        fail=$((fail + 1))
    fi
    echo "parity: $name $line allowed=$allowed $verdict"
done
echo "parity: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
