#!/bin/sh
# Out of memory loses nothing: every command that writes files is run once
# for each allocation it makes, with that one allocation failing
# (tests/oom/failat.c, preloaded). Each run must either succeed with the
# same outputs as a run with memory to spare, or fail with a message, a
# non-zero exit and no signal, every output as it was and no temporary
# file left beside it.
#   sh tests/oom.sh build/lancer
# The preload needs a build without sanitizers (their allocator comes
# first); with one, the test says so and skips. Prints "oom: N passed, N
# failed" and fails if any check failed.
set -u
LANCER=$(cd "$(dirname "$1")" && pwd)/$(basename "$1")
ROOT=$(pwd)
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
. "$(dirname "$0")/tally.sh"

${CC:-cc} -O2 -shared -fPIC "$ROOT/tests/oom/failat.c" -o "$T/failat.so" || { echo "oom: cannot build the preload"; exit 1; }
if ldd "$LANCER" 2>/dev/null | grep -q 'libasan\|libtsan\|libmsan'; then
    echo "oom: $LANCER is sanitized, and the preload needs a plain build: skipped"
    exit 0
fi

mkdir "$T/w"
cd "$T/w" || exit 1
cp "$ROOT/scenes/default.scn" default.scn
cp "$ROOT/scenes/parity/pn.scn" pn.scn
cp "$ROOT/scenes/parity/icosahedron.off" icosahedron.off
sed -i 's|"[./]*icosahedron.off"|"icosahedron.off"|' pn.scn
printf 'OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n' >tet.off
S="--width 48 --height 36"
"$LANCER" render default.scn -o a.exr $S -q && "$LANCER" render default.scn -o b.exr $S --spp 2 -q &&
    "$LANCER" render default.scn -o top.exr $S --region 0:48,0:20 -q &&
    "$LANCER" render default.scn -o bottom.exr $S --region 0:48,20:36 -q || { echo "oom: the inputs failed"; exit 1; }

# sweep NAME OUTPUTS -- CMD...: CMD once with memory to spare (the
# reference outputs), then once for each of its allocations failing.
sweep() {
    name=$1
    outs=$2
    shift 3
    rm -rf ref && mkdir ref
    for o in $outs; do rm -f "$o"; done
    if ! FAIL_COUNT="$T/count" LD_PRELOAD="$T/failat.so" "$@" >/dev/null 2>"$T/err"; then
        bad "$name: fails with memory to spare: $(head -c 300 "$T/err")"
        return
    fi
    for o in $outs; do cp "$o" "ref/$(echo "$o" | tr / _)"; done
    n=$(cat "$T/count")
    [ "$n" -gt 0 ] && ok || bad "$name: no allocation counted"
    i=1
    while [ "$i" -le "$n" ]; do
        for o in $outs; do echo "old $o" >"$o"; done
        FAIL_AT=$i LD_PRELOAD="$T/failat.so" timeout 30 "$@" >/dev/null 2>"$T/err"
        rc=$?
        problem=
        if [ "$rc" -eq 0 ]; then
            for o in $outs; do cmp -s "$o" "ref/$(echo "$o" | tr / _)" || problem="$problem $o differs from the reference;"; done
        elif [ "$rc" -ge 124 ]; then
            problem="exit $rc (a signal, or a hang);"
        else
            for o in $outs; do [ "$(cat "$o")" = "old $o" ] || problem="$problem $o replaced;"; done
            [ -s "$T/err" ] || problem="$problem no message;"
        fi
        left=$(ls -a | grep -c 'lancer-tmp')
        [ "$left" -eq 0 ] || problem="$problem $left temporary files left;"
        rm -f .*lancer-tmp* *lancer-tmp*
        if [ -n "$problem" ]; then bad "$name, allocation $i of $n fails: exit $rc:$problem $(head -c 200 "$T/err")"; else ok; fi
        i=$((i + 1))
    done
}

sweep "render, EXR and PNG" "o.exr o.png" -- "$LANCER" render default.scn -o o.exr --png o.png $S --threads 2 -q
sweep "render, PN patches and a mesh" "o.exr" -- "$LANCER" render pn.scn -o o.exr $S -q
sweep "export-pov" "o.pov" -- "$LANCER" export-pov pn.scn -o o.pov
sweep "diff --heatmap" "h.png" -- "$LANCER" diff a.exr b.exr --heatmap h.png
sweep "merge" "m.exr" -- "$LANCER" merge top.exr bottom.exr -o m.exr
mkdir rays
sweep "bench --gen-rays" "rays/primary.rays rays/shadow.rays rays/diffuse.rays" -- "$LANCER" bench --gen-rays tet.off rays 16 16

tally oom
