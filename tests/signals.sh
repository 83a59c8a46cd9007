#!/bin/sh
# Stopping cleanly: SIGTERM and SIGINT at several moments of a render (while
# it loads, renders and writes), a second signal, SIGKILL, and a full disk.
# Whatever the moment, the previous outputs stay as they were unless the
# run completes, a new output is never truncated, a stopped render leaves
# its finished rows in <output>.partial.exr, and no temporary file is left
# (after SIGKILL, the next run to the same output removes them).
#   sh tests/signals.sh build/san/lancer
# Prints "signals: N passed, N failed". The full-disk checks mount a 64 KiB
# tmpfs, which needs root; without it they are skipped with a message.
set -u
LANCER=$(cd "$(dirname "$1")" && pwd)/$(basename "$1")
ROOT=$(pwd)
T=$(mktemp -d)
MNT=""
cleanup() {
    if [ -n "$MNT" ]; then umount "$MNT"; fi
    rm -rf "$T"
}
trap cleanup EXIT
. "$(dirname "$0")/tally.sh"
. "$(dirname "$0")/finish.sh"

# A background job of sh starts with SIGINT ignored, which lancer then
# keeps ignoring; perl (in every Debian) restores the default first.
run_bg() {
    perl -e '$SIG{INT} = "DEFAULT"; exec @ARGV or die "exec: $!"' "$LANCER" "$@" >"$T/out" 2>"$T/err" &
    pid=$!
}

# A render that takes seconds to render, then seconds to write: a large
# image of sky, whose pixels are cheap and whose files are big.
printf 'image { width 5000 height 5000 }\ncamera { eye 0 0 0 target 0 1 1 fov 40 }\n' >"$T/sky.scn"

# valid_exr FILE: lancer reads every pixel of FILE.
valid_exr() { "$LANCER" diff "$1" "$1" >/dev/null 2>&1; }

# no_temporaries: no file of a run is left in $T.
no_temporaries() {
    if ls "$T" | grep -q lancer-tmp; then
        bad "$1: temporary files left: $(ls "$T" | grep lancer-tmp) (pid ${pid:-}; stderr: $(head -c 300 "$T/err"))"
    else
        ok
    fi
}

# check LABEL RC: the outputs after a run that ended with status RC.
check() {
    label=$1
    rc=$2
    case $rc in
    0)
        if valid_exr "$T/a.exr"; then ok; else bad "$label: exit 0 but a.exr is not a whole EXR"; fi
        if head -c 8 "$T/a.png" | od -An -c | grep -q "P   N   G"; then ok; else bad "$label: exit 0 but no new a.png"; fi
        ;;
    130 | 143)
        if [ "$(cat "$T/a.exr")" = "old exr" ] && [ "$(cat "$T/a.png")" = "old png" ]; then ok; else
            bad "$label: stopped (exit $rc), yet the old outputs changed"
        fi
        if [ -e "$T/a.partial.exr" ]; then
            if valid_exr "$T/a.partial.exr"; then ok; else bad "$label: a.partial.exr is not a whole EXR"; fi
            if exrheader "$T/a.partial.exr" | grep -Eq 'lancer:rows \(type string\): "[0-9][0-9,-]*"'; then ok; else
                bad "$label: a.partial.exr records no rows"
            fi
        fi
        ;;
    *) bad "$label: exit $rc, wanted 0, 130 or 143 ($(head -c 300 "$T/err"))" ;;
    esac
    no_temporaries "$label"
}

reset_outputs() {
    echo "old exr" >"$T/a.exr"
    echo "old png" >"$T/a.png"
    rm -f "$T/a.partial.exr"
}

# One signal at several moments: while loading, rendering, writing.
for sig in TERM INT; do
    for delay in 0.05 0.5 2 3.5 5 7; do
        reset_outputs
        run_bg render "$T/sky.scn" -o "$T/a.exr" --png "$T/a.png" --threads 2
        sleep "$delay"
        kill -s "$sig" "$pid" 2>/dev/null
        finish "$pid"
        check "SIG$sig after ${delay}s" $?
    done
done

# Stopped while rendering: exit 143 or 130, the rows done so far kept, and
# the message says where. At 16 samples a pixel the render lasts many times
# the second before the signal, on a machine and a build of any speed.
reset_outputs
run_bg render "$T/sky.scn" -o "$T/a.exr" --png "$T/a.png" --threads 2 --spp 16
sleep 1
kill -s TERM "$pid"
finish "$pid"
rc=$?
if [ "$rc" -eq 143 ]; then ok; else bad "SIGTERM while rendering: exit $rc, wanted 143"; fi
if grep -q "rows saved in $T/a.partial.exr; $T/a.exr is unchanged" "$T/err"; then ok; else
    bad "SIGTERM while rendering: $(cat "$T/err")"
fi
check "SIGTERM while rendering" "$rc"
rows=$(exrheader "$T/a.partial.exr" 2>/dev/null | sed -n 's/.*lancer:rows (type string): "\(.*\)"/\1/p')
case $rows in
0-[0-9]*) ok ;;
*) bad "SIGTERM while rendering: rows '$rows' do not start at row 0" ;;
esac
reset_outputs
run_bg render "$T/sky.scn" -o "$T/a.exr" --png "$T/a.png" --threads 2 --spp 16
sleep 1
kill -s INT "$pid"
finish "$pid"
rc=$?
if [ "$rc" -eq 130 ]; then ok; else bad "SIGINT while rendering: exit $rc, wanted 130"; fi
check "SIGINT while rendering" "$rc"

# Stopped within a pixel: one pixel of glass in glass at depth 256, whose
# every hit spawns a mirror ray and a refracted one of weight 1, a tree of
# 2^256 rays. The signal stops the trace, not only the next pixel: exit 143
# before a row was done (it once ran on until killed).
cat >"$T/tree.scn" <<'SCN'
image { width 1 height 1 max_depth 256 }
camera { eye 0 0 -5 target 0 0 0 fov 10 }
light { position -6 9 -6 }
material g { color 1 1 1 reflection 1 transmit 1 ior 1.5 }
sphere { center 0 0 0 radius 1 material g }
sphere { center 0 0 0 radius 3 material g }
SCN
reset_outputs
run_bg render "$T/tree.scn" -o "$T/a.exr" --png "$T/a.png" --threads 1
sleep 1
kill -s TERM "$pid"
finish "$pid"
rc=$?
if [ "$rc" -eq 143 ]; then ok; else bad "SIGTERM within a pixel: exit $rc, wanted 143"; fi
if grep -q "stopped by SIGTERM before a row was done" "$T/err"; then ok; else bad "SIGTERM within a pixel: $(head -c 300 "$T/err")"; fi
check "SIGTERM within a pixel" "$rc"

# A second signal exits at once, leaving nothing half written.
for delay in 0.5 3; do
    reset_outputs
    run_bg render "$T/sky.scn" -o "$T/a.exr" --png "$T/a.png" --threads 2
    sleep "$delay"
    kill -s TERM "$pid" 2>/dev/null
    sleep 0.2
    kill -s TERM "$pid" 2>/dev/null
    finish "$pid"
    check "two SIGTERMs after ${delay}s" $?
done

# A completed render removes the partial image a stopped one left.
reset_outputs
run_bg render "$T/sky.scn" -o "$T/a.exr" --png "$T/a.png" --threads 2 --spp 16
sleep 1
kill -s TERM "$pid"
finish "$pid"
if [ -e "$T/a.partial.exr" ]; then ok; else bad "no partial image after SIGTERM"; fi
"$LANCER" render "$T/sky.scn" -o "$T/a.exr" --png "$T/a.png" --width 16 --height 16 -q
if [ -e "$T/a.partial.exr" ]; then bad "a complete render left the stale partial image"; else ok; fi

# SIGKILL at any moment: the old outputs or whole new ones, never a
# truncated file; the next run to the same outputs removes what was left.
for delay in 0.5 2 3.5 5 6; do
    reset_outputs
    run_bg render "$T/sky.scn" -o "$T/a.exr" --png "$T/a.png" --threads 2
    sleep "$delay"
    kill -s KILL "$pid" 2>/dev/null
    finish "$pid"
    if [ "$(cat "$T/a.exr" 2>/dev/null)" = "old exr" ] || valid_exr "$T/a.exr"; then ok; else
        bad "SIGKILL after ${delay}s: a.exr is neither the old file nor a whole new one"
    fi
    if [ "$(cat "$T/a.png")" = "old png" ] || head -c 8 "$T/a.png" | od -An -c | grep -q "P   N   G"; then ok; else
        bad "SIGKILL after ${delay}s: a.png is neither the old file nor a new one"
    fi
    "$LANCER" render "$T/sky.scn" -o "$T/a.exr" --png "$T/a.png" --width 16 --height 16 -q
    no_temporaries "the run after SIGKILL after ${delay}s"
done

# A full disk: a clear error, nothing half written, and the outputs of one
# run all new or all as they were.
if mkdir "$T/disk" && mount -t tmpfs -o size=64k lancer-test "$T/disk" 2>/dev/null; then
    MNT="$T/disk"
    echo "old exr" >"$MNT/a.exr"
    echo "old png" >"$MNT/a.png"
    # the EXR alone does not fit
    "$LANCER" render "$ROOT/scenes/default.scn" -o "$MNT/a.exr" --width 640 --height 480 -q 2>"$T/err"
    rc=$?
    if [ "$rc" -eq 1 ]; then ok; else bad "full disk: exit $rc, wanted 1"; fi
    if grep -q "$MNT/a.exr: cannot write: .*No space left on device" "$T/err"; then ok; else bad "full disk: $(cat "$T/err")"; fi
    # full_pair LABEL THREADS MESSAGE: the EXR and the PNG on the full disk,
    # MESSAGE (an extended regular expression) the error wanted; neither is
    # replaced and nothing is left
    full_pair() {
        "$LANCER" render "$ROOT/scenes/default.scn" -o "$MNT/a.exr" --png "$MNT/a.png" --width 256 --height 192 \
            -q --threads "$2" 2>"$T/err"
        rc=$?
        if [ "$rc" -eq 1 ]; then ok; else bad "$1: exit $rc, wanted 1"; fi
        if grep -Eq "$3" "$T/err"; then ok; else bad "$1: $(cat "$T/err")"; fi
        if [ "$(cat "$MNT/a.exr")" = "old exr" ] && [ "$(cat "$MNT/a.png")" = "old png" ]; then ok; else
            bad "$1: a mixed set of outputs"
        fi
        if [ "$(ls "$MNT" | tr '\n' ' ')" = "a.exr a.png " ]; then ok; else bad "$1: left $(ls "$MNT")"; fi
    }
    # the EXR fits, the PNG then does not (one thread writes them in turn)
    full_pair "full disk, PNG" 1 "$MNT/a\.png: cannot write: No space left on device"
    # two threads write them side by side: whichever runs out of room says so
    full_pair "full disk, side by side" 2 "$MNT/a\.(exr|png): cannot write: .*No space left on device"
    # the PNG elsewhere, on the full disk: the EXR on a roomy one is not committed
    echo "old exr" >"$T/b.exr"
    dd if=/dev/zero of="$MNT/fill" bs=1k count=52 2>/dev/null
    "$LANCER" render "$ROOT/scenes/default.scn" -o "$T/b.exr" --png "$MNT/a.png" --width 256 --height 192 -q \
        2>"$T/err"
    if [ "$(cat "$T/b.exr")" = "old exr" ]; then ok; else bad "full disk: the EXR was committed without its PNG"; fi
    no_temporaries "full disk"
    umount "$MNT"
    MNT=""
else
    echo "signals: skipped the full-disk checks (mounting a tmpfs needs root)"
fi

tally signals
