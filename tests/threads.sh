#!/bin/sh
# Data races, found by ThreadSanitizer: lancer built with SAN=thread runs
# what runs threads side by side, and any report fails the check. The BVH
# built on two threads (a mesh), the render's rows on several, the EXR's
# chunks beside the PNG, merge's writing, and the stop flag that a signal
# handler sets while the render's threads read it.
#   sh tests/threads.sh build/tsan/lancer
# Prints "threads: N passed, N failed".
set -u
LANCER=$(cd "$(dirname "$1")" && pwd)/$(basename "$1")
ROOT=$(pwd)
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
. "$(dirname "$0")/tally.sh"
. "$(dirname "$0")/finish.sh"
# every report printed (exit 66 on one), none stopping the run
TSAN_OPTIONS="halt_on_error=0 exitcode=66"
export TSAN_OPTIONS

# race LABEL RC: the run ended as wanted, with no report in $T/err.
race() {
    if grep -q "ThreadSanitizer" "$T/err"; then
        bad "$1: $(grep -A12 'WARNING: ThreadSanitizer' "$T/err" | head -24)"
    else
        ok
    fi
}
expect() { # expect LABEL WANT CMD...: runs CMD with its stderr in $T/err
    label=$1 want=$2
    shift 2
    "$@" >"$T/out" 2>"$T/err"
    rc=$?
    if [ "$rc" -eq "$want" ]; then ok; else bad "$label: exit $rc, wanted $want ($(head -c 300 "$T/err"))"; fi
    race "$label"
}

cd "$ROOT" || exit 1
# renders: the BVH of a mesh of 8,192 triangles (a wavy grid), built on two
# threads and more, the rows on as many, the EXR beside the PNG and the stats
awk 'BEGIN {
    n = 64; print "OFF"; print (n + 1) * (n + 1), 2 * n * n, 0
    for (j = 0; j <= n; j++) for (i = 0; i <= n; i++) print i / n - 0.5, 0.1 * sin(9 * i / n) * cos(7 * j / n), j / n - 0.5
    for (j = 0; j < n; j++) for (i = 0; i < n; i++) {
        a = j * (n + 1) + i; print 3, a, a + 1, a + n + 2; print 3, a, a + n + 2, a + n + 1
    }
}' >"$T/grid.off"
cat >"$T/grid.scn" <<SCN
camera { eye 0 1.2 -1.2 target 0 0 0 fov 50 }
light { position 1 3 -2 }
material m { color 0.8 0.7 0.6 reflection 0.2 }
mesh { file "$T/grid.off" material m }
SCN
for n in 2 4; do
    expect "a mesh on $n threads" 0 "$LANCER" render "$T/grid.scn" --width 96 --height 72 --threads $n \
        -o "$T/g$n.exr" --png "$T/g$n.png" --stats "$T/g$n.json" -q
done
expect "a PN mesh on 2 threads" 0 "$LANCER" render scenes/parity/pn.scn --width 64 --height 48 --threads 2 \
    -o "$T/pn.exr" -q
expect "adaptive anti-aliasing on 3 threads" 0 "$LANCER" render scenes/parity/adaptive.scn --width 64 --height 48 \
    --threads 3 -o "$T/ad.exr" -q
expect "frames on 2 threads" 0 "$LANCER" render scenes/orbit.scn --width 48 --height 36 --frames 0:3 --threads 2 \
    -o "$T/o%d.exr" --png "$T/o%d.png" -q
# tiles merged on 3 threads
expect "tile 0" 0 "$LANCER" render scenes/default.scn --width 64 --height 48 --region 0:64,0:24 -o "$T/t0.exr" -q
expect "tile 1" 0 "$LANCER" render scenes/default.scn --width 64 --height 48 --region 0:64,24:48 -o "$T/t1.exr" -q
expect "merge on 3 threads" 0 "$LANCER" merge --threads 3 -q -o "$T/m.exr" --png "$T/m.png" "$T/t0.exr" "$T/t1.exr"

# a signal while two threads render: the handler's flag, read by both
# (16 samples a pixel: the render lasts many times the second before it)
printf 'image { width 2000 height 2000 }\ncamera { eye 0 0 0 target 0 1 1 fov 40 }\n' >"$T/sky.scn"
perl -e '$SIG{INT} = "DEFAULT"; exec @ARGV or die "exec: $!"' "$LANCER" render "$T/sky.scn" -o "$T/s.exr" \
    --threads 2 --spp 16 -q >"$T/out" 2>"$T/err" &
pid=$!
sleep 1
kill -s TERM "$pid" 2>/dev/null
finish "$pid"
rc=$?
if [ "$rc" -eq 143 ]; then ok; else bad "SIGTERM on 2 threads: exit $rc, wanted 143 ($(head -c 300 "$T/err"))"; fi
race "SIGTERM on 2 threads"

tally threads
