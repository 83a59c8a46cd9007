#!/usr/bin/env bash
# Renders a scene with GNU parallel, on local workers or on ssh hosts: every
# tile, then the merge; or every frame. See README.md, "Running on a
# cluster".
set -euo pipefail

usage() {
    cat <<'TXT'
usage: scripts/parallel-render.sh [options] SCENE OUT.exr [-- RENDER-OPTIONS...]

Renders SCENE with GNU parallel and waits for it:
  tiles (default): one job per region of `lancer tiles`, each writing
    DIR/tile.NNNN.exr, then `lancer merge` writes OUT.exr here;
  --frames A:B: one job per frame A..B-1, each writing OUT with the frame
    number put in its pattern (OUT must hold %d or %0Nd).
Every job runs `lancer render ... --resume`, so running the same command
again after a failure or Ctrl-C renders only what is missing.

options:
  --lancer PATH      the lancer binary, the same path on every host (default: lancer on PATH)
  --tiles N          N tiles (default: 4 per job slot)
  --frames A:B       render frames A to B-1 instead of tiles
  --jobs N           jobs at once on each host (default: 1 per CPU on local workers)
  --threads N        threads of each render, and of the merge (default 1)
  --sshlogin LIST    parallel's --sshlogin: hosts to run on, e.g. "4/node1,4/node2"
                     (they need lancer, the scene, its meshes and DIR at the same paths)
  --out-dir DIR      where the tiles and the job log go (default: OUT-stem.tiles/)
  -h, --help         show this help

Exit status: 0 when every job and the merge succeeded; 1 otherwise, after
naming the failed tiles or frames (parallel's job log is DIR/jobs.log).
TXT
}

die() {
    echo "parallel-render: $*" >&2
    exit 1
}

lancer=lancer tiles="" frames="" jobs="" threads=1 sshlogin="" outdir=""
while [ $# -gt 0 ]; do
    case $1 in
    -h | --help) usage; exit 0 ;;
    --lancer) lancer=${2:?--lancer needs a path}; shift 2 ;;
    --tiles) tiles=${2:?--tiles needs a number}; shift 2 ;;
    --frames) frames=${2:?--frames needs A:B}; shift 2 ;;
    --jobs) jobs=${2:?--jobs needs a number}; shift 2 ;;
    --threads) threads=${2:?--threads needs a number}; shift 2 ;;
    --sshlogin) sshlogin=${2:?--sshlogin needs hosts}; shift 2 ;;
    --out-dir) outdir=${2:?--out-dir needs a folder}; shift 2 ;;
    --) break ;;
    -*) usage >&2; die "unknown option '$1'" ;;
    *) break ;;
    esac
done
[ $# -ge 2 ] || { usage >&2; die "needs SCENE and OUT.exr"; }
scene=$1 out=$2
shift 2
[ "${1:-}" = "--" ] && shift
command -v parallel >/dev/null || die "GNU parallel not found (Debian: apt-get install parallel)"
command -v "$lancer" >/dev/null || die "lancer not found: '$lancer' (use --lancer PATH)"
[ -f "$scene" ] || die "no scene file '$scene'"
[ -n "$tiles" ] && [ -n "$frames" ] && die "--tiles and --frames exclude each other"
for n in "$threads" ${jobs:+"$jobs"} ${tiles:+"$tiles"}; do
    case $n in '' | *[!0-9]* | 0) die "a count must be a whole number from 1, not '$n'" ;; esac
done

abspath() { case $1 in /*) printf '%s\n' "$1" ;; *) printf '%s/%s\n' "$(pwd)" "$1" ;; esac; }
lancer=$(abspath "$(command -v "$lancer")")
scene=$(abspath "$scene")
out=$(abspath "$out")
stem=${out%.exr}
outdir=$(abspath "${outdir:-$stem.tiles}")
mkdir -p "$outdir"

par=(parallel --will-cite --quote --halt never --joblog "$outdir/jobs.log" --tag)
[ -n "$jobs" ] && par+=(--jobs "$jobs")
[ -n "$sshlogin" ] && par+=(--sshlogin "$sshlogin")
render=("$lancer" render "$scene" --threads "$threads" --resume -q "$@")

if [ -n "$frames" ]; then
    case $frames in *:*) ;; *) die "--frames needs A:B, not '$frames'" ;; esac
    a=${frames%%:*} b=${frames#*:}
    case $a$b in '' | *[!0-9]*) die "--frames needs A:B of whole numbers, not '$frames'" ;; esac
    [ "$a" -lt "$b" ] || die "--frames A:B needs A < B, not '$frames'"
    case $out in *%*d*) ;; *) die "$out: several frames need a frame pattern such as %04d" ;; esac
    if "${par[@]}" "${render[@]}" -o "$out" --frame {} ::: $(seq "$a" $((b - 1))); then
        exit 0
    fi
    failed=$(awk 'NR > 1 && $7 != 0 { print $NF }' "$outdir/jobs.log" | tr '\n' ' ')
    die "frames failed: ${failed:-?} (see $outdir/jobs.log)"
fi

if [ -z "$tiles" ]; then
    slots=${jobs:-$(nproc)}
    tiles=$((4 * slots))
fi
size=()
prev=""
for a in "$@"; do
    case $prev in --width | --height) size+=("$prev" "$a") ;; esac
    case $a in --width=* | --height=*) size+=("$a") ;; esac
    prev=$a
done
"$lancer" tiles "$scene" --count "$tiles" "${size[@]}" >"$outdir/regions" || die "lancer tiles failed"
count=$(wc -l <"$outdir/regions")
# job k renders line k of the regions into tile.k
seq 0 $((count - 1)) | paste - "$outdir/regions" >"$outdir/jobs"
if ! "${par[@]}" --colsep '\t' "${render[@]}" --region {2} -o "$outdir/tile.{=1 \$_=sprintf('%04d', \$_) =}.exr" \
    :::: "$outdir/jobs"; then
    failed=$(awk -F'\t' 'NR > 1 && $7 != 0 { print $NF }' "$outdir/jobs.log" | grep -o 'tile\.[0-9]*\.exr' | tr '\n' ' ')
    die "tiles failed: ${failed:-?} (see $outdir/jobs.log); run the same command again to finish them"
fi
tilefiles=()
for ((i = 0; i < count; i++)); do tilefiles+=("$outdir/tile.$(printf %04d "$i").exr"); done
"$lancer" merge -q --threads "$threads" -o "$out" "${tilefiles[@]}"
echo "parallel-render: $count tiles merged into $out"
