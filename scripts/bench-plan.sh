#!/bin/sh
# What the render plan saves: every scene of scenes/*.scn, scenes/parity/*.scn
# and scenes/stability/*.scn is rendered with the plan (the default) and with
# --no-plan (which traces everything the plan would skip: shadow rays toward
# lights that nothing can shadow, reflection and refraction rays of
# coefficient 0), in turns, RUNS times each, on one thread (--threads 1),
# at the size and spp of each scene file, -q, to a temporary directory that
# is removed at the end. The time is the "render" phase of --stats
# ("phases_s"): it counts neither parsing, set-up nor output. Each time is a
# median of RUNS; the ratio is the median of the runs' own ratios (the two
# renders of a ratio ran a moment apart, so the shared machine's slow spells
# cancel), so it need not equal the quotient of the two medians. Rays are
# deterministic: the counts by kind are those of the first run of each side.
# The first two renders of a scene are also compared with cmp: the plan must
# not change the picture (a difference is reported on stderr and counted in
# the summary). Not a test: it asserts nothing (a failed render is reported
# and its row marked), and exits non-zero only for a bad RUNS or a LANCER
# that cannot be copied.
#
#   sh scripts/bench-plan.sh [LANCER] [RUNS]
#
# LANCER defaults to build/lancer, RUNS to 5. LANCER is copied into the
# temporary directory first, so that a rebuild during the run changes
# nothing. Scenes that use the CGAL meshes (bunny.scn) are skipped, with a
# note, when build/cgal-data/meshes/bunny00.off is missing (make cgal-data).
#
# Prints a markdown table, one row per scene: the median render time with
# the plan and without, the ratio no plan / plan, and the shadow, reflection
# and refraction rays of both sides (camera rays are the same on both sides
# and shown in the scene column); then one summary line: in how many scenes
# the plan traced fewer rays (deterministic, unlike the times: on a noisy
# machine a scene whose rays are the same on both sides gives the noise of
# the ratio), and the render times summed over the scenes.
set -u
LANCER=${1:-build/lancer}
RUNS=${2:-5}
case $RUNS in '' | *[!0-9]* | 0) echo "bench-plan: RUNS must be a positive integer, not '$RUNS'" >&2; exit 2 ;; esac
MESH=build/cgal-data/meshes/bunny00.off
WORK=$(mktemp -d "${TMPDIR:-/tmp}/bench-plan.XXXXXX") || exit 1
trap 'rm -rf "$WORK"' EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
cp "$LANCER" "$WORK/lancer" || { echo "bench-plan: cannot copy $LANCER" >&2; exit 1; }
BIN=$WORK/lancer

# value JSON SECTION KEY: the number KEY of the object SECTION ("phases_s",
# "rays") of a --stats file, wherever its lines break
value() {
    awk -v sec="\"$2\":" -v key="\"$3\":" '
        { all = all " " $0 }
        END {
            s = index(all, sec); if (!s) exit
            obj = substr(all, s + length(sec)); obj = substr(obj, 1, index(obj, "}"))
            k = index(obj, key); if (!k) exit
            v = substr(obj, k + length(key)); sub(/^[ \t]*/, "", v); sub(/[,} \t].*$/, "", v)
            print v
        }' "$1"
}

# render SCENE SIDE I: renders SCENE with the plan (SIDE plan) or without
# (SIDE noplan), run I; the stats go to $WORK/SIDE-I.json. Non-zero if the
# render failed.
render() {
    np=""
    [ "$2" = noplan ] && np=--no-plan
    "$BIN" render "$1" --threads 1 -q ${np:+"$np"} -o "$WORK/$2-$3.exr" \
        --stats "$WORK/$2-$3.json" 2>"$WORK/$2-$3.log"
}

# rays KIND: the rays of KIND of the first run, "plan / no plan"
rays() { echo "$(value "$WORK/plan-1.json" rays "$1") / $(value "$WORK/noplan-1.json" rays "$1")"; }

median() { sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }

rows=0
skipped=0
failed=0
differ=0
fewer=0
sum_plan=0
sum_noplan=0
echo "| scene | render s (plan) | render s (no plan) | no plan / plan | shadow rays (plan / no plan) | reflection rays | refraction rays |"
echo "| --- | --- | --- | --- | --- | --- | --- |"
for scn in scenes/*.scn scenes/parity/*.scn scenes/stability/*.scn; do
    [ -f "$scn" ] || continue
    if grep -q 'cgal-data/meshes/' "$scn" && [ ! -f "$MESH" ]; then
        echo "| $scn | skipped: $MESH is missing (make cgal-data) | | | | | |"
        skipped=$((skipped + 1))
        continue
    fi
    : >"$WORK/runs"
    ok=1
    i=1
    while [ "$i" -le "$RUNS" ]; do
        for side in plan noplan; do
            if ! render "$scn" "$side" "$i"; then
                echo "bench-plan: $scn ($side, run $i): $(tail -n 1 "$WORK/$side-$i.log")" >&2
                ok=0
                break 2
            fi
        done
        p=$(value "$WORK/plan-$i.json" phases_s render)
        n=$(value "$WORK/noplan-$i.json" phases_s render)
        echo "$p $n" >>"$WORK/runs"
        [ "$i" -eq 1 ] || rm -f "$WORK/plan-$i.exr" "$WORK/noplan-$i.exr"
        i=$((i + 1))
    done
    if [ "$ok" -eq 0 ]; then
        echo "| $scn | failed (see stderr) | | | | | |"
        failed=$((failed + 1))
        continue
    fi
    if ! cmp -s "$WORK/plan-1.exr" "$WORK/noplan-1.exr"; then
        echo "bench-plan: $scn: the picture with --no-plan differs from the planned one" >&2
        differ=$((differ + 1))
    fi
    tp=$(awk '{print $1}' "$WORK/runs" | median)
    tn=$(awk '{print $2}' "$WORK/runs" | median)
    ratio=$(awk '$1 > 0 {print $2 / $1}' "$WORK/runs" | median)
    printf '| %s (%s camera rays) | %.3f | %.3f | %.2f | %s | %s | %s |\n' "$scn" \
        "$(value "$WORK/plan-1.json" rays camera)" "$tp" "$tn" "${ratio:-0}" \
        "$(rays shadow)" "$(rays reflection)" "$(rays refraction)"
    rows=$((rows + 1))
    if [ "$(value "$WORK/plan-1.json" rays total)" != "$(value "$WORK/noplan-1.json" rays total)" ]; then
        fewer=$((fewer + 1))
    fi
    sum_plan=$(awk -v a="$sum_plan" -v b="$tp" 'BEGIN {print a + b}')
    sum_noplan=$(awk -v a="$sum_noplan" -v b="$tn" 'BEGIN {print a + b}')
    rm -f "$WORK"/plan-* "$WORK"/noplan-*
done

printf 'bench-plan: %d scenes, medians of %d runs in turns on 1 thread; the plan traces fewer rays in %d; render time summed over the scenes %.3f s with the plan, %.3f s without (%.2fx); %d skipped, %d failed, %d pictures differ\n' \
    "$rows" "$RUNS" "$fewer" "$sum_plan" "$sum_noplan" \
    "$(awk -v a="$sum_plan" -v b="$sum_noplan" 'BEGIN {print (a > 0) ? b / a : 0}')" \
    "$skipped" "$failed" "$differ"
