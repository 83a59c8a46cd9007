#!/bin/sh
# Runs each libFuzzer harness (tests/fuzz) for SECONDS, and fails on any
# crash, sanitizer report, broken promise, timeout or allocation over the
# limit. The seeds are made fresh from the repository: the good and bad
# inputs of the unit tests (test_x --seeds), the scenes, and EXRs and ray
# files that lancer writes. The corpus grows in build/fuzz-corpus between
# runs. An input that fails is copied to tests/fuzz/regressions/NAME/, which
# `make test` replays: commit it with the fix.
#   sh scripts/fuzz.sh build/fuzz build/san SECONDS [NAME...]
# Prints one line per harness: executions, corpus size, and the verdict.
set -u
fz=$1
san=$2
secs=$3
shift 3
names=${*:-scene off obj ply stl exr rays}
seeds=build/fuzz-seeds
corpus=build/fuzz-corpus
out=build/fuzz-out
rm -rf "$seeds" "$out"
mkdir -p "$seeds/scene" "$seeds/rays" "$out"

# The seeds.
for t in mesh scene image; do
    "$san/test_$t" --seeds "$seeds" || { echo "fuzz: $san/test_$t --seeds failed" >&2; exit 1; }
done
# the scenes, named by their folder too: scenes/bunny.scn and
# scenes/parity/bunny.scn are different seeds
for f in scenes/*.scn scenes/*/*.scn; do
    cp "$f" "$seeds/scene/$(echo "$f" | tr / -)"
done
printf 'image { width 6 height 4 }\ncamera { eye 0 1 -4 target 0 0 0 fov 50 }\nlight { position 2 4 -3 }\n'\
'material m { color 1 0.5 0.2 }\nsphere { center 0 0 0 radius 1 material m }\n' >"$seeds/tiny.scn"
"$san/lancer" render "$seeds/tiny.scn" -o "$seeds/exr/lancer-half.exr" -q &&
    "$san/lancer" render "$seeds/tiny.scn" -o "$seeds/exr/lancer-float.exr" --float -q &&
    "$san/lancer" render "$seeds/tiny.scn" -o "$seeds/exr/lancer-tile.exr" --region 1:5,1:3 -q || exit 1
printf 'OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n' >"$seeds/tet.off"
"$san/lancer" bench --gen-rays "$seeds/tet.off" "$seeds/rays" 4 4 >/dev/null || exit 1
printf 'LNCRAYS1\002\0\0\0\0\0\0\0' >"$seeds/rays/short"
rm "$seeds/tiny.scn" "$seeds/tet.off"

failed=0
for n in $names; do
    mkdir -p "$corpus/$n"
    dict=tests/fuzz/$n.dict
    # -max_len for EXRs: a header may ask for 786 KiB of pixels per byte of
    # its file (src/image.c), which 2 KiB keeps under the malloc limit.
    maxlen=""
    if [ "$n" = exr ]; then maxlen=-max_len=2048; fi
    "$fz/fuzz_$n" "$corpus/$n" "$seeds/$n" -dict="$dict" -max_total_time="$secs" -timeout=10 \
        -rss_limit_mb=4096 -malloc_limit_mb=2048 -print_final_stats=1 $maxlen \
        -artifact_prefix="$out/$n-" >"$out/$n.log" 2>&1
    rc=$?
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$out/$n.log")
    units=$(ls "$corpus/$n" | wc -l)
    if [ "$rc" -eq 0 ]; then
        echo "fuzz $n: ${execs:-?} executions in ${secs} s, corpus $units inputs: no finding"
    else
        failed=$((failed + 1))
        echo "fuzz $n: FAILED (exit $rc) after ${execs:-?} executions; the log's end:"
        tail -n 30 "$out/$n.log"
        mkdir -p "tests/fuzz/regressions/$n"
        for a in "$out/$n-"*; do
            [ -f "$a" ] || continue
            cp "$a" "tests/fuzz/regressions/$n/"
            echo "fuzz $n: kept $a in tests/fuzz/regressions/$n/ (commit it with the fix)"
        done
    fi
done
[ "$failed" -eq 0 ]
