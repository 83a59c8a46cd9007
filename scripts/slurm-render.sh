#!/usr/bin/env bash
# Renders a scene on a Slurm cluster: a job array of tiles and a merge job
# that waits for it, or a job array of frames. See README.md, "Running on a
# cluster".
set -euo pipefail

usage() {
    cat <<'TXT'
usage: scripts/slurm-render.sh [options] SCENE OUT.exr [-- RENDER-OPTIONS...]

Submits the render of SCENE to Slurm and prints the job ids, then returns:
  tiles (default): one array task per region of `lancer tiles`, each writing
    DIR/tile.NNNN.exr, and a merge job (--dependency=afterok on the array)
    that writes OUT.exr;
  --frames A:B: one array task per frame A..B-1, each writing OUT with the
    frame number put in its pattern (OUT must hold %d or %0Nd).
Every task runs `lancer render ... --resume`: submitting the same command
again renders only what is missing. A finished tile or frame is left as it
is, and a task stopped by scancel or its time limit (SIGTERM, then SIGKILL
after KillWait) continues from its partial image. When a tile fails or is
cancelled, Slurm cancels the merge job too (--kill-on-invalid-dep=yes).

options:
  --lancer PATH       the lancer binary, on every node (default: lancer on PATH)
  --tiles N           N tiles (default: 2 per CPU of the partition's first node, at least 4)
  --frames A:B        render frames A to B-1 instead of tiles
  --out-dir DIR       where the tiles, lists and logs go (default: OUT-stem.tiles/,
                      or OUT-stem.frames/ for the logs of frames)
  --time T            each task's time limit (sbatch --time), e.g. 0:30:00
  --partition P       the partition (default: the cluster's default)
  --cpus-per-task N   threads of each task (default 1); lancer renders and merges with as many
  --sbatch-args ARGS  more arguments for every sbatch, split at blanks
  -h, --help          show this help

The scene, its meshes and DIR must be on storage that every node sees at the
same path. Prints "array=ID merge=ID" (tiles) or "array=ID" (frames).
TXT
}

die() {
    echo "slurm-render: $*" >&2
    exit 1
}

lancer=lancer tiles="" frames="" outdir="" time="" partition="" cpus=1 extra=""
while [ $# -gt 0 ]; do
    case $1 in
    -h | --help) usage; exit 0 ;;
    --lancer) lancer=${2:?--lancer needs a path}; shift 2 ;;
    --tiles) tiles=${2:?--tiles needs a number}; shift 2 ;;
    --frames) frames=${2:?--frames needs A:B}; shift 2 ;;
    --out-dir) outdir=${2:?--out-dir needs a folder}; shift 2 ;;
    --time) time=${2:?--time needs a limit}; shift 2 ;;
    --partition) partition=${2:?--partition needs a name}; shift 2 ;;
    --cpus-per-task) cpus=${2:?--cpus-per-task needs a number}; shift 2 ;;
    --sbatch-args) extra=${2?--sbatch-args needs arguments}; shift 2 ;;
    --) break ;;
    -*) usage >&2; die "unknown option '$1'" ;;
    *) break ;;
    esac
done
[ $# -ge 2 ] || { usage >&2; die "needs SCENE and OUT.exr"; }
scene=$1 out=$2
shift 2
[ "${1:-}" = "--" ] && shift
command -v sbatch >/dev/null || die "sbatch not found: is this a Slurm login node?"
command -v "$lancer" >/dev/null || die "lancer not found: '$lancer' (use --lancer PATH)"
[ -f "$scene" ] || die "no scene file '$scene'"
case $cpus in '' | *[!0-9]* | 0) die "--cpus-per-task needs a whole number from 1, not '$cpus'" ;; esac
[ -n "$tiles" ] && [ -n "$frames" ] && die "--tiles and --frames exclude each other"

# absolute paths: the jobs start in other folders, on other nodes
abspath() { case $1 in /*) printf '%s\n' "$1" ;; *) printf '%s/%s\n' "$(pwd)" "$1" ;; esac; }
lancer=$(command -v "$lancer")
lancer=$(abspath "$lancer")
scene=$(abspath "$scene")
out=$(abspath "$out")
# the folder's default name without the frame pattern
stem=$(printf '%s' "${out%.exr}" | sed 's/%0*[0-9]*d//g; s/%%/%/g')
kind=tiles
[ -n "$frames" ] && kind=frames
outdir=$(abspath "${outdir:-$stem.$kind}")
mkdir -p "$outdir/log"
# sbatch's -o reads % as its own patterns
logs=$(printf '%s' "$outdir/log" | sed 's/%/%%/g')

sb=(sbatch --parsable --cpus-per-task="$cpus")
[ -n "$time" ] && sb+=(--time="$time")
[ -n "$partition" ] && sb+=(--partition="$partition")
# shellcheck disable=SC2206
[ -n "$extra" ] && sb+=($extra)
render=("$lancer" render "$scene" --threads "$cpus" --resume "$@")
# the render's arguments, quoted for the job scripts
args=$(printf '%q ' "${render[@]}")

if [ -n "$frames" ]; then
    case $frames in *:*) ;; *) die "--frames needs A:B, not '$frames'" ;; esac
    a=${frames%%:*} b=${frames#*:}
    case $a$b in '' | *[!0-9]*) die "--frames needs A:B of whole numbers, not '$frames'" ;; esac
    [ "$a" -lt "$b" ] || die "--frames A:B needs A < B, not '$frames'"
    case $out in *%*d*) ;; *) die "$out: several frames need a frame pattern such as %04d" ;; esac
    array=$("${sb[@]}" --job-name=lancer-frames --array=0-$((b - a - 1)) -o "$logs/frame.%a.log" <<JOB
#!/bin/sh
exec $args --frame \$(($a + SLURM_ARRAY_TASK_ID)) -o $(printf '%q' "$out")
JOB
)
    echo "array=${array%%;*}"
    exit 0
fi

if [ -z "$tiles" ]; then
    n=$(sinfo -h -o %c ${partition:+-p "$partition"} 2>/dev/null | head -n 1 | tr -dc 0-9)
    tiles=$((2 * ${n:-2}))
    [ "$tiles" -ge 4 ] || tiles=4
fi
case $tiles in '' | *[!0-9]* | 0) die "--tiles needs a whole number from 1, not '$tiles'" ;; esac
# the size options of the render decide the image's size
size=()
prev=""
for a in "$@"; do
    case $prev in --width | --height) size+=("$prev" "$a") ;; esac
    case $a in --width=* | --height=*) size+=("$a") ;; esac
    prev=$a
done
"$lancer" tiles "$scene" --count "$tiles" "${size[@]}" >"$outdir/regions" || die "lancer tiles failed"
count=$(wc -l <"$outdir/regions")
array=$("${sb[@]}" --job-name=lancer-tiles --array=0-$((count - 1)) -o "$logs/tile.%a.log" <<JOB
#!/bin/sh
region=\$(sed -n "\$((SLURM_ARRAY_TASK_ID + 1))p" $(printf '%q' "$outdir/regions"))
exec $args --region "\$region" -o $(printf '%q' "$outdir")/tile.\$(printf %04d "\$SLURM_ARRAY_TASK_ID").exr
JOB
)
array=${array%%;*}
names=""
for ((i = 0; i < count; i++)); do names+=" $(printf '%q' "$outdir/tile.$(printf %04d "$i").exr")"; done
# a failed or cancelled tile cancels the merge, rather than leaving it
# pending for ever; submitting again renders what is missing and merges
merge=$("${sb[@]}" --job-name=lancer-merge --dependency=afterok:"$array" --kill-on-invalid-dep=yes -o "$logs/merge.log" <<JOB
#!/bin/sh
exec $(printf '%q' "$lancer") merge --threads $cpus -o $(printf '%q' "$out")$names
JOB
)
echo "array=$array merge=${merge%%;*}"
