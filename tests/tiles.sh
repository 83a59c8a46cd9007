#!/bin/sh
# Regions, tiles, merging, frames and resuming: every pixel of a tile, a
# merged image, a frame of a range and a resumed render is the single
# render's, bit for bit; merge refuses every bad set of tiles, and loses
# nothing when it does.
#   sh tests/tiles.sh build/san/lancer
# Prints "tiles: N passed, N failed" and fails if any check failed.
set -u
LANCER=$(cd "$(dirname "$1")" && pwd)/$(basename "$1")
ROOT=$(pwd)
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
. "$(dirname "$0")/tally.sh"
. "$(dirname "$0")/finish.sh"
expect() {
    want=$1
    shift
    "$@" >"$T/out" 2>"$T/err"
    got=$?
    if [ "$got" -eq "$want" ]; then ok; else bad "exit $got, wanted $want: $* ($(head -c 300 "$T/err"))"; fi
}
has() { if grep -qF -- "$2" "$1"; then ok; else bad "$1 lacks '$2': $(head -c 300 "$1")"; fi; }
# same A B: the two EXR files are byte for byte the same (same pixels,
# windows and stamp).
same() { if cmp -s "$1" "$2"; then ok; else bad "$1 and $2 differ: $("$LANCER" diff "$1" "$2" 2>&1)"; fi; }

cp "$ROOT/scenes/orbit.scn" "$T/orbit.scn"
# a scene with a mesh, whose content the stamp covers
printf 'OFF\n4 2 0\n-1 0 -1\n1 0 -1\n1 0 1\n-1 0 1\n3 0 1 2\n3 0 2 3\n' >"$T/floor.off"
cat >"$T/mesh.scn" <<'SCN'
image { width 40 height 30 spp 3 aa_threshold 0.05 }
camera { eye 0 1.5 -4 target 0 0 0 fov 50 }
light { position 2 4 -3 }
material m { color 1 0.5 0.2 phong 0.5 }
material f { color 0.8 0.8 0.8 }
sphere { center 0 0.6 0 radius 0.6 material m }
mesh { file "floor.off" material f scale 3 }
SCN
O="--width 61 --height 45 --spp 3 --aa-threshold 0.05"

# tiles: N regions covering the image once, or regions of a size
expect 0 "$LANCER" tiles "$T/orbit.scn" --count 6 --width 61 --height 45
if [ "$(wc -l <"$T/out")" -eq 6 ]; then ok; else bad "tiles --count 6 printed $(wc -l <"$T/out") lines"; fi
has "$T/out" "0:20,0:22"
has "$T/out" "40:61,22:45"
cp "$T/out" "$T/six"
expect 0 "$LANCER" tiles "$T/orbit.scn" --size 32x32
if [ "$(cat "$T/out" | tr '\n' ' ')" = "0:32,0:32 32:64,0:32 64:96,0:32 96:128,0:32 128:160,0:32 160:192,0:32 192:224,0:32 224:256,0:32 256:288,0:32 288:320,0:32 0:32,32:64 " ] ||
    [ "$(wc -l <"$T/out")" -eq 80 ]; then ok; else bad "tiles --size 32x32 of 320x240: $(head -3 "$T/out")"; fi
expect 0 "$LANCER" tiles "$T/orbit.scn" --count 7
if [ "$(wc -l <"$T/out")" -eq 7 ]; then ok; else bad "tiles --count 7: $(cat "$T/out")"; fi
expect 2 "$LANCER" tiles "$T/orbit.scn"
has "$T/err" "needs one of --count N and --size WxH"
expect 2 "$LANCER" tiles "$T/orbit.scn" --count 4 --size 8x8
expect 2 "$LANCER" tiles "$T/orbit.scn" --size 8by8
has "$T/err" "--size needs WxH"
# numbers past int are refused, not wrapped (4294967301 wrapped to 5); no sign, no blank
expect 2 "$LANCER" tiles "$T/orbit.scn" --size 4294967301x5
has "$T/err" "--size needs WxH"
expect 2 "$LANCER" tiles "$T/orbit.scn" --size +5x5
expect 1 "$LANCER" tiles "$T/orbit.scn" --count 7 --width 5 --height 5
has "$T/err" "cannot be split into 7 regions"
# an image render refuses, tiles refuses too
expect 1 "$LANCER" tiles "$T/orbit.scn" --count 4 --width 32768 --height 32768
has "$T/err" "more than the 268435456 pixels lancer renders"

# regions: bad ones are refused before any work
expect 2 "$LANCER" render "$T/orbit.scn" --region 0:10 -o "$T/r.exr"
has "$T/err" "--region needs X0:X1,Y0:Y1"
expect 2 "$LANCER" render "$T/orbit.scn" --region 5:5,0:4 -o "$T/r.exr"
expect 2 "$LANCER" render "$T/orbit.scn" --region 0:4294967306,0:10 -o "$T/r.exr"
has "$T/err" "--region needs X0:X1,Y0:Y1"
expect 2 "$LANCER" render "$T/orbit.scn" --region "0:4, 0:4" -o "$T/r.exr"
expect 1 "$LANCER" render "$T/orbit.scn" $O --region 0:62,0:4 -o "$T/r.exr"
has "$T/err" "the region 0:62,0:4 is empty or not inside the 61x45 image"

# six tiles, rendered on 1 and 2 threads, merge into the single render, and
# their PNG into its PNG (a preview of the half EXR's values)
expect 0 "$LANCER" render "$T/orbit.scn" $O -q -o "$T/full.exr" --png "$T/full.png"
i=0
for r in $(cat "$T/six"); do
    expect 0 "$LANCER" render "$T/orbit.scn" $O -q --region "$r" --threads $((i % 2 + 1)) -o "$T/t$i.exr"
    i=$((i + 1))
done
expect 0 "$LANCER" merge -o "$T/m.exr" --png "$T/m.png" "$T/t5.exr" "$T/t0.exr" "$T/t1.exr" "$T/t2.exr" "$T/t3.exr" "$T/t4.exr"
has "$T/err" "merged 6 tiles into $T/m.exr (61x45)"
same "$T/m.exr" "$T/full.exr"
if head -c 8 "$T/m.png" | od -An -c | grep -q "P   N   G"; then ok; else bad "merge --png wrote no PNG"; fi
same "$T/m.png" "$T/full.png"
# on one thread and on three (the EXR's chunks beside the PNG): the same bytes
T6="$T/t0.exr $T/t1.exr $T/t2.exr $T/t3.exr $T/t4.exr $T/t5.exr"
expect 0 "$LANCER" merge --threads 1 -q -o "$T/m1.exr" --png "$T/m1.png" $T6
expect 0 "$LANCER" merge --threads 3 -q -o "$T/m3.exr" --png "$T/m3.png" $T6
same "$T/m1.exr" "$T/full.exr"
same "$T/m3.exr" "$T/full.exr"
same "$T/m1.png" "$T/m.png"
same "$T/m3.png" "$T/m.png"
expect 2 "$LANCER" merge --threads 0 -o "$T/m0.exr" $T6
has "$T/err" "--threads"
# OpenImageIO places the tiles by their data windows too
if command -v oiiotool >/dev/null 2>&1; then
    oiiotool --info -v "$T/t4.exr" >"$T/info" 2>&1
    has "$T/info" "pixel data origin: x=20, y=22"
    has "$T/info" "full/display size: 61 x 45"
    oiiotool "$T/t0.exr" "$T/t1.exr" --add "$T/t2.exr" --add "$T/t3.exr" --add "$T/t4.exr" --add "$T/t5.exr" --add \
        -o "$T/oiio.exr" >/dev/null 2>&1
    "$LANCER" diff "$T/full.exr" "$T/oiio.exr" >"$T/out" 2>&1
    has "$T/out" "max=0 mean=0"
else
    echo "tiles: oiiotool missing (openimageio-tools): its checks skipped"
fi

# merge refuses, and the output stays as it was
echo "precious" >"$T/keep.exr"
expect 1 "$LANCER" merge -o "$T/keep.exr" "$T/t0.exr" "$T/t1.exr" "$T/t2.exr" "$T/t3.exr" "$T/t4.exr"
has "$T/err" "the tiles leave 483 of the 61x45 picture's pixels uncovered, the first at (40, 22)"
expect 1 "$LANCER" merge -o "$T/keep.exr" "$T/t0.exr" "$T/t1.exr" "$T/t2.exr" "$T/t3.exr" "$T/t4.exr" "$T/t5.exr" "$T/t3.exr"
has "$T/err" "$T/t3.exr: its region 0:20,22:45 overlaps $T/t3.exr's 0:20,22:45"
expect 0 "$LANCER" render "$T/orbit.scn" $O -q --region 0:30,0:45 -o "$T/left.exr"
expect 1 "$LANCER" merge -o "$T/keep.exr" "$T/left.exr" "$T/t1.exr"
has "$T/err" "overlaps"
expect 0 "$LANCER" render "$T/orbit.scn" $O --spp 2 -q --region 0:20,0:22 -o "$T/spp2.exr"
expect 1 "$LANCER" merge -o "$T/keep.exr" "$T/t1.exr" "$T/spp2.exr" "$T/t2.exr" "$T/t3.exr" "$T/t4.exr" "$T/t5.exr"
has "$T/err" "$T/spp2.exr: rendered with spp=2, not spp=3, unlike $T/t1.exr"
# with the classic routines the loop and the tree can differ at an edge, so
# tiles of both do not merge (they once did)
expect 0 "$LANCER" render "$T/orbit.scn" $O --classic --accel loop -q --region 0:20,0:22 -o "$T/cl-loop.exr"
expect 0 "$LANCER" render "$T/orbit.scn" $O --classic -q --region 20:40,0:22 -o "$T/cl-bvh.exr"
expect 1 "$LANCER" merge -o "$T/keep.exr" "$T/cl-loop.exr" "$T/cl-bvh.exr"
has "$T/err" "$T/cl-bvh.exr: rendered with intersect=classic-bvh, not intersect=classic-loop, unlike $T/cl-loop.exr"
# half and float tiles, and tiles of the scene moved, do not merge either
T15="$T/t1.exr $T/t2.exr $T/t3.exr $T/t4.exr $T/t5.exr"
expect 0 "$LANCER" render "$T/orbit.scn" $O --float -q --region 0:20,0:22 -o "$T/float.exr"
expect 1 "$LANCER" merge -o "$T/keep.exr" "$T/float.exr" $T15
has "$T/err" "$T/t1.exr: rendered with channels=half, not channels=float, unlike $T/float.exr"
expect 0 "$LANCER" render "$T/orbit.scn" $O --scale 2 -q --region 0:20,0:22 -o "$T/scale2.exr"
expect 1 "$LANCER" merge -o "$T/keep.exr" "$T/scale2.exr" $T15
has "$T/err" "$T/t1.exr: rendered with scale=1, not scale=2, unlike $T/scale2.exr"
# regions that share a single column overlap
expect 0 "$LANCER" render "$T/orbit.scn" $O -q --region 0:21,0:22 -o "$T/t0wide.exr"
expect 1 "$LANCER" merge -o "$T/keep.exr" "$T/t0wide.exr" $T15
has "$T/err" "$T/t1.exr: its region 20:40,0:22 overlaps $T/t0wide.exr's 0:21,0:22"
# a tile whose picture is another size than the first's, its stamp the same
# (its display window one row taller, by perl-base)
perl -0777 -pe 's/(displayWindow\0box2i\0\x10\0\0\0.{12})(.{4})/$1 . pack("l<", unpack("l<", $2) + 1)/se' "$T/t1.exr" >"$T/taller.exr"
expect 1 "$LANCER" merge -o "$T/keep.exr" "$T/t0.exr" "$T/taller.exr"
has "$T/err" "$T/taller.exr: is a tile of a 61x46 picture, $T/t0.exr of 61x45"
expect 0 "$LANCER" render "$T/orbit.scn" $O --frame 3 -q --region 0:20,0:22 -o "$T/f3.exr"
expect 1 "$LANCER" merge -o "$T/keep.exr" "$T/f3.exr" "$T/t1.exr" "$T/t2.exr" "$T/t3.exr" "$T/t4.exr" "$T/t5.exr"
has "$T/err" "$T/t1.exr: is frame still, not 3, unlike $T/f3.exr"
sed 's/fov 40 }/fov 41 }/' "$T/orbit.scn" >"$T/orbit2.scn"
expect 0 "$LANCER" render "$T/orbit2.scn" $O -q --region 0:20,0:22 -o "$T/stale.exr"
expect 1 "$LANCER" merge -o "$T/keep.exr" "$T/stale.exr" "$T/t1.exr" "$T/t2.exr" "$T/t3.exr" "$T/t4.exr" "$T/t5.exr"
has "$T/err" "rendered from another scene, or from its files as they were before they changed"
head -c $(($(wc -c <"$T/t2.exr") / 2)) "$T/t2.exr" >"$T/cut.exr"
expect 1 "$LANCER" merge -o "$T/keep.exr" "$T/t0.exr" "$T/t1.exr" "$T/cut.exr" "$T/t3.exr" "$T/t4.exr" "$T/t5.exr"
has "$T/err" "$T/cut.exr: cannot read"
# a tile of a picture past the pixel limit (its display window made
# 32768 square, by perl-base, in every Debian) names the limit
perl -0777 -pe 's/(displayWindow\0box2i\0\x10\0\0\0.{8}).{8}/$1 . pack("l<l<", 32767, 32767)/se' "$T/t0.exr" >"$T/huge.exr"
expect 1 "$LANCER" merge -o "$T/keep.exr" "$T/huge.exr"
has "$T/err" "$T/huge.exr: is a tile of a 32768x32768 picture, past lancer's limits"
expect 0 "$LANCER" diff "$T/full.exr" "$T/full.exr" --heatmap "$T/h.png"
expect 1 "$LANCER" merge -o "$T/keep.exr" "$T/nothere.exr"
has "$T/err" "$T/nothere.exr: cannot open"
expect 1 "$LANCER" merge -o "$T/t0.exr" "$T/t0.exr" "$T/t1.exr"
has "$T/err" "lancer never writes over its inputs"
expect 2 "$LANCER" merge "$T/t0.exr"
has "$T/err" "needs -o OUT.exr"
if [ "$(cat "$T/keep.exr")" = "precious" ]; then ok; else bad "a refused merge changed its output"; fi

# a mesh changed between tiles: the stamp catches the stale tile
expect 0 "$LANCER" render "$T/mesh.scn" -q --region 0:40,0:15 -o "$T/top.exr"
printf 'OFF\n4 2 0\n-1 0 -1\n1 0 -1\n1 0.1 1\n-1 0 1\n3 0 1 2\n3 0 2 3\n' >"$T/floor.off"
expect 0 "$LANCER" render "$T/mesh.scn" -q --region 0:40,15:30 -o "$T/bottom.exr"
expect 1 "$LANCER" merge -o "$T/keep.exr" "$T/top.exr" "$T/bottom.exr"
has "$T/err" "$T/bottom.exr: rendered from another scene"

# frames: a range in one process, each frame the single frame's
expect 0 "$LANCER" render "$T/orbit.scn" --width 48 --height 36 --frames 10:14 -q -o "$T/f.%04d.exr"
expect 0 "$LANCER" render "$T/orbit.scn" --width 48 --height 36 --frame 12 -q -o "$T/one.exr"
same "$T/one.exr" "$T/f.0012.exr"
if [ -e "$T/f.0010.exr" ] && [ -e "$T/f.0013.exr" ] && [ ! -e "$T/f.0014.exr" ]; then ok; else bad "--frames 10:14 wrote $(ls "$T" | grep '^f\.')"; fi
expect 0 "$LANCER" render "$T/orbit.scn" --width 48 --height 36 --frame 0 -q -o "$T/k0.exr"
expect 0 "$LANCER" render "$T/orbit.scn" --width 48 --height 36 -q -o "$T/still.exr"
"$LANCER" diff "$T/k0.exr" "$T/still.exr" >"$T/out" 2>&1
has "$T/out" "max=0 mean=0" # frame 0's key is the camera block's view
expect 2 "$LANCER" render "$T/orbit.scn" --frames 0:2 -o "$T/nopattern.exr"
has "$T/err" "several frames need a frame pattern in the name, such as %04d"
expect 2 "$LANCER" render "$T/orbit.scn" --frames 3:3
has "$T/err" "--frames needs A:B"
expect 2 "$LANCER" render "$T/orbit.scn" --frame 1 --frames 0:2
expect 2 "$LANCER" render "$T/orbit.scn" --frames 0:4294967298 -o "$T/f.%d.exr"
has "$T/err" "--frames needs A:B"
# frame 10's image would replace frame 0's preview: refused before the first frame
expect 2 "$LANCER" render "$T/orbit.scn" --width 8 --height 6 --frames 0:11 -o "$T/c%d.exr" --png "$T/c1%d.exr"
has "$T/err" "--png of frame 0 ($T/c10.exr) and -o of frame 10 ($T/c10.exr) are one file; each output needs a file of its own"
if [ -e "$T/c0.exr" ]; then bad "a frame was rendered before the clash was found"; else ok; fi
# the same with the folder spelled another way, and with frame 10's partial
# image, which its end removes: frame 0's statistics would be lost
expect 2 "$LANCER" render "$T/orbit.scn" --width 8 --height 6 --frames 0:11 -o "$T/c%d.exr" --stats "$T/./c1%d.exr"
has "$T/err" "--stats of frame 0 ($T/./c10.exr) and -o of frame 10 ($T/c10.exr) are one file"
# and two files of one frame, frame 10's, when frames 8 and 9 are not
expect 2 "$LANCER" render "$T/orbit.scn" --width 8 --height 6 --frames 8:11 -o "$T/c%d.exr" --stats "$T/c%02d.exr"
has "$T/err" "-o of frame 10 ($T/c10.exr) and --stats of frame 10 ($T/c10.exr) are one file"
if [ -e "$T/c8.exr" ]; then bad "frame 8 was rendered before frame 10's clash was found"; else ok; fi
expect 2 "$LANCER" render "$T/orbit.scn" --width 8 --height 6 --frames 0:11 -o "$T/c%d.exr" --stats "$T/c1%d.partial.exr"
has "$T/err" "--stats of frame 0 ($T/c10.partial.exr) and the partial image of -o of frame 10 ($T/c10.partial.exr) are one file"
if [ -e "$T/c0.exr" ]; then bad "a frame was rendered before the clash was found"; else ok; fi
# a '%' in the scene's name is not a pattern of the default output's
mkdir "$T/pct" && cp "$T/orbit.scn" "$T/pct/o%x.scn"
if (cd "$T/pct" && "$LANCER" render "o%x.scn" --frame 1 --width 8 --height 6 -q) && [ -s "$T/pct/out/o%x.0001.exr" ]; then ok; else
    bad "render --frame of o%x.scn did not write out/o%x.0001.exr"
fi
expect 2 "$LANCER" render "$T/orbit.scn" --frames 0:2 -o "$T/f.%s.exr"
has "$T/err" "a frame pattern is %d or %0Nd"
# a malformed pattern is a usage error with one frame too, before the scene is read
expect 2 "$LANCER" render "$T/orbit.scn" --frame 1 -o "$T/f.%010d.exr"
has "$T/err" "a frame pattern is %d or %0Nd"
expect 1 "$LANCER" render "$T/mesh.scn" --frame 1 -o "$T/x.exr"
has "$T/err" "the scene has no camera path"
# --resume skips the frames already complete
expect 0 "$LANCER" render "$T/orbit.scn" --width 48 --height 36 --frames 10:15 --resume -o "$T/f.%04d.exr"
has "$T/err" "$T/f.0013.exr is complete, from this scene and these settings; nothing to do"
has "$T/err" "wrote $T/f.0014.exr"
# a complete output leaves --png and --stats unwritten, and says so even with -q
expect 0 "$LANCER" render "$T/orbit.scn" --width 48 --height 36 --frame 13 --resume -q -o "$T/f.0013.exr" --png "$T/f13.png"
has "$T/err" "--png not written: it comes with a render, and there was none"

# resume: stopped by SIGTERM, resumed on another thread count, the same file
R="--width 2000 --height 1500 --spp 3 --aa-threshold 0.05"
t0=$(date +%s.%N)
expect 0 "$LANCER" render "$T/orbit.scn" $R -q --threads 2 -o "$T/ref.exr"
# stopped a quarter of the way through (of the reference's time): midway on
# a machine and a build of any speed, where a fixed wait let a fast one finish
stop=$(awk -v a="$t0" -v b="$(date +%s.%N)" 'BEGIN { printf "%.3f", (b - a) / 4 }')
perl -e 'exec @ARGV or die' "$LANCER" render "$T/orbit.scn" $R --threads 2 -o "$T/big.exr" >"$T/out" 2>"$T/err" &
pid=$!
sleep "$stop"
kill -s TERM "$pid"
finish "$pid"
rc=$?
if [ "$rc" -eq 143 ] && [ -e "$T/big.partial.exr" ]; then
    ok
    expect 0 "$LANCER" render "$T/orbit.scn" $R --threads 1 --resume -o "$T/big.exr"
    has "$T/err" "resuming from $T/big.partial.exr"
    same "$T/big.exr" "$T/ref.exr"
    if [ -e "$T/big.partial.exr" ]; then bad "the partial image outlived its resumed render"; else ok; fi
else
    bad "the render to resume was not stopped midway (exit $rc): $(cat "$T/err")"
fi
# a partial image of other settings or another region is refused, and kept
perl -e 'exec @ARGV or die' "$LANCER" render "$T/orbit.scn" $R --threads 2 -o "$T/big2.exr" >"$T/out" 2>"$T/err" &
pid=$!
sleep "$stop"
kill -s TERM "$pid"
finish "$pid"
if [ -e "$T/big2.partial.exr" ]; then
    expect 1 "$LANCER" render "$T/orbit.scn" $R --spp 2 --resume -o "$T/big2.exr"
    has "$T/err" "cannot resume from $T/big2.partial.exr: it was rendered with spp=3, not spp=2; remove it to render from the start"
    expect 1 "$LANCER" render "$T/orbit.scn" $R --region 0:100,0:100 --resume -o "$T/big2.exr"
    has "$T/err" "it holds the region 0:2000,0:1500 of a 2000x1500 picture, not 0:100,0:100 of 2000x1500"
    if [ -e "$T/big2.partial.exr" ]; then ok; else bad "a refused resume removed the partial image"; fi
    expect 1 "$LANCER" merge -o "$T/keep.exr" "$T/big2.partial.exr"
    has "$T/err" "is a partial render (rows 0-"
else
    bad "the second render to resume was not stopped midway: $(cat "$T/err")"
fi

tally tiles
