#!/bin/bash
# make test-cluster: lancer on a real scheduler. Starts a one-node Slurm
# cluster on this machine (tests/cluster/slurm.sh), submits the recipes of
# scripts/slurm-render.sh, and checks that the merged image and every frame
# equal a single process's render, byte for byte; cancels a tile midway and
# shows that submitting again resumes it; then the same with GNU parallel
# (scripts/parallel-render.sh, local workers). Stops every daemon it started
# and prints the figures: jobs, tiles, wall times.
#   bash tests/cluster.sh [LANCER]      (as root: the daemons run as root)
# Prints "cluster: N passed, N failed" and fails if any check failed.
set -u
LANCER=$(cd "$(dirname "${1:-build/lancer}")" && pwd)/$(basename "${1:-build/lancer}")
ROOT=$(pwd)
. "$(dirname "$0")/tally.sh"
same() { if cmp -s "$1" "$2"; then ok; else bad "$3: $1 differs from $2: $("$LANCER" diff "$1" "$2" 2>&1)"; fi; }
now() { date +%s.%N; }
secs() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.1f", b - a }'; }

if [ "$(id -u)" -ne 0 ]; then
    echo "cluster: skipped: starting the Slurm daemons needs root"
    exit 0
fi
for c in slurmctld slurmd sbatch munged parallel; do
    command -v "$c" >/dev/null || { echo "cluster: $c is missing (scripts/deps.sh test)"; exit 1; }
done
. "$ROOT/tests/cluster/slurm.sh"
T=$(mktemp -d /tmp/lancer-cluster.XXXXXX)
cleanup() {
    slurm_stop "$T/slurm"
    rm -rf "$T"
}
trap cleanup EXIT
trap 'exit 1' INT TERM

t0=$(now)
slurm_start "$T/slurm" || exit 1
echo "cluster: Slurm up in $(secs "$t0" "$(now)") s ($(cat "$T/slurm/auth"), $(nproc) CPUs, KillWait 5 s)"
ok

W=$T/work
mkdir -p "$W"
cp "$ROOT/scenes/orbit.scn" "$W/orbit.scn"
SR="$ROOT/scripts/slurm-render.sh"
PR="$ROOT/scripts/parallel-render.sh"
R="--width 480 --height 360 --spp 3 --aa-threshold 0.05"

# ids "array=A merge=M" into $array and $merge
ids() {
    array=$(sed -n 's/.*array=\([0-9]*\).*/\1/p' "$1")
    merge=$(sed -n 's/.*merge=\([0-9]*\).*/\1/p' "$1")
}
# all STATE: every task of job $1 ended in state $2
all_states() {
    states=$(slurm_state "$1" | sort | uniq -c | tr -s ' ' | tr '\n' ',')
    if [ "$(slurm_state "$1" | grep -vcx "$2")" -eq 0 ] && [ -n "$(slurm_state "$1")" ]; then ok; else
        bad "job $1: states $states, wanted all $2"
    fi
}

# 1. tiles: a job array and a merge job, against one process on one
# thread and on every CPU (Slurm runs one single-threaded task a CPU)
B="--width 1280 --height 960 --spp 8"
t0=$(now)
"$LANCER" render "$W/orbit.scn" $B --threads 1 -q -o "$W/big-single.exr"
single1=$(secs "$t0" "$(now)")
t0=$(now)
"$LANCER" render "$W/orbit.scn" $B -q -o "$W/big-single-all.exr"
singleall=$(secs "$t0" "$(now)")
same "$W/big-single-all.exr" "$W/big-single.exr" "threads"
t0=$(now)
"$SR" --lancer "$LANCER" --tiles 8 "$W/orbit.scn" "$W/tiled.exr" -- $B >"$W/ids" 2>"$W/err" || bad "slurm-render: $(cat "$W/err")"
ids "$W/ids"
if slurm_wait "$merge" 600; then ok; else bad "the tiles and merge did not finish in 600 s: $(squeue)"; fi
wall=$(secs "$t0" "$(now)")
all_states "$array" COMPLETED
all_states "$merge" COMPLETED
same "$W/tiled.exr" "$W/big-single.exr" "Slurm tiles"
echo "cluster: Slurm, 8 tiles of 1280x960 (spp 8), array $array (8 jobs) and merge $merge: ${wall} s from submission" \
    "to the merged image; one process: ${single1} s on 1 thread, ${singleall} s on $(nproc); merged = single:" \
    "$(cmp -s "$W/tiled.exr" "$W/big-single.exr" && echo bit-identical || echo DIFFERENT)"
"$LANCER" render "$W/orbit.scn" $R --threads 1 -q -o "$W/single.exr"

# 2. frames: one task a frame, each equal to the single frame
t0=$(now)
"$SR" --lancer "$LANCER" --frames 20:26 "$W/orbit.scn" "$W/f.%04d.exr" -- --width 160 --height 120 >"$W/ids" 2>"$W/err" ||
    bad "slurm-render --frames: $(cat "$W/err")"
ids "$W/ids"
if slurm_wait "$array" 300; then ok; else bad "the frames did not finish in 300 s"; fi
all_states "$array" COMPLETED
for f in 20 23 25; do
    "$LANCER" render "$W/orbit.scn" --width 160 --height 120 --frame $f -q -o "$W/one.exr"
    same "$W/f.00$f.exr" "$W/one.exr" "Slurm frame $f"
done
echo "cluster: Slurm, frames 20 to 25 at 160x120: array $array (6 jobs), $(secs "$t0" "$(now)") s"

# 3. a tile cancelled midway (SIGTERM from scancel), then the same command
# again: the finished tiles are kept, the cancelled one resumes
"$SR" --lancer "$LANCER" --tiles 4 "$W/orbit.scn" "$W/big.exr" -- $B >"$W/ids" 2>"$W/err" || bad "slurm-render: $(cat "$W/err")"
ids "$W/ids"
first_array=$array first_merge=$merge
# until task 1 runs, then a quarter of a tile's time (a tile is a quarter of
# the single render on one thread): a tile cut short on a machine of any
# speed, where a fixed wait let a fast one finish first
delay=$(awk -v s="$single1" 'BEGIN { t = s / 16; printf "%.2f", t < 0.3 ? 0.3 : t }')
i=0
while [ $i -lt 240 ] && [ -z "$(squeue -h -t R -j "${array}_1" 2>/dev/null)" ]; do
    sleep 0.25
    i=$((i + 1))
done
sleep "$delay"
scancel "${array}_1"
if slurm_wait "$array" 300; then ok; else bad "the array did not end in 300 s"; fi
state1=$(scontrol -o show job "${array}_1" | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p')
if [ "$state1" = CANCELLED ]; then ok; else bad "task 1 ended $state1, not CANCELLED"; fi
if [ -e "$W/big.tiles/tile.0001.partial.exr" ] && [ ! -e "$W/big.tiles/tile.0001.exr" ]; then ok; else
    bad "the cancelled tile left no partial image: $(ls "$W/big.tiles"; cat "$W/big.tiles/log/tile.1.log")"
fi
saved=$(grep -o '[0-9]* of [0-9]* rows saved' "$W/big.tiles/log/tile.1.log")
if slurm_wait "$merge" 120; then ok; else bad "the merge job outlived its cancelled tile: $(squeue)"; fi
mstate=$(slurm_state "$merge")
if [ "$mstate" = CANCELLED ]; then ok; else bad "the merge job ended $mstate, not CANCELLED"; fi
t0=$(now)
"$SR" --lancer "$LANCER" --tiles 4 "$W/orbit.scn" "$W/big.exr" -- $B >"$W/ids" 2>"$W/err" || bad "slurm-render again: $(cat "$W/err")"
ids "$W/ids"
if slurm_wait "$merge" 300; then ok; else bad "the resubmission did not finish in 300 s"; fi
all_states "$merge" COMPLETED
for k in 0 2 3; do
    if grep -q "nothing to do" "$W/big.tiles/log/tile.$k.log"; then ok; else bad "tile $k was rendered again"; fi
done
if grep -q "resuming from .*tile.0001.partial.exr" "$W/big.tiles/log/tile.1.log"; then ok; else
    bad "tile 1 did not resume: $(cat "$W/big.tiles/log/tile.1.log")"
fi
same "$W/big.exr" "$W/big-single.exr" "cancelled and resumed tiles"
echo "cluster: Slurm, 4 tiles of 1280x960 (spp 8): task ${first_array}_1 cancelled by scancel $delay s after it started ($saved), merge" \
    "$first_merge cancelled by Slurm (--kill-on-invalid-dep); resubmitted as $array and $merge: 3 tiles skipped, 1" \
    "resumed, $(secs "$t0" "$(now)") s; merged = single: $(cmp -s "$W/big.exr" "$W/big-single.exr" && echo bit-identical || echo DIFFERENT)"

# 4. GNU parallel, two local workers: tiles, then frames, in a folder whose
# name has a blank and a shell's metacharacters (parallel once split the
# paths at the blank and would have run the rest)
P="$W/a b;\$(false)"
mkdir -p "$P"
cp "$W/orbit.scn" "$P/orbit.scn"
"$LANCER" render "$P/orbit.scn" $R --threads 1 -q -o "$P/single.exr" # (the stamp names the scene's path)
"$LANCER" render "$P/orbit.scn" --width 160 --height 120 --frame 23 -q -o "$P/one.exr"
t0=$(now)
if "$PR" --lancer "$LANCER" --jobs 2 --tiles 6 "$P/orbit.scn" "$P/par.exr" -- $R >"$W/out" 2>&1; then ok; else
    bad "parallel-render: $(cat "$W/out")"
fi
same "$P/par.exr" "$P/single.exr" "GNU parallel tiles"
echo "cluster: GNU parallel, 6 tiles of 480x360 on 2 workers: $(secs "$t0" "$(now)") s; merged = single:" \
    "$(cmp -s "$P/par.exr" "$P/single.exr" && echo bit-identical || echo DIFFERENT)"
if "$PR" --lancer "$LANCER" --jobs 2 --frames 20:26 "$P/orbit.scn" "$P/p.%04d.exr" -- --width 160 --height 120 >"$W/out" 2>&1; then
    ok
else
    bad "parallel-render --frames: $(cat "$W/out")"
fi
same "$P/p.0023.exr" "$P/one.exr" "GNU parallel frame 23"
# a failing tile is named, and the exit status says so
if "$PR" --lancer "$LANCER" --jobs 2 --tiles 2 "$W/orbit.scn" "$W/fail.exr" -- --spp 99 >"$W/out" 2>&1; then
    bad "parallel-render succeeded with a bad option"
else
    if grep -q "tiles failed: .*tile.0000.exr" "$W/out"; then ok; else bad "parallel-render's failure: $(cat "$W/out")"; fi
fi

# every daemon stopped, by its process id
pids="$(cat "$T/slurm/slurmctld.bgpid" "$T/slurm/slurmd.bgpid" "$T/slurm/munge/pid" 2>/dev/null)"
slurm_stop "$T/slurm"
left=""
for p in $pids; do kill -0 "$p" 2>/dev/null && left="$left $p"; done
if [ -z "$left" ]; then ok; else bad "daemons still running: $left"; fi
tally cluster
