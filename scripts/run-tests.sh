#!/bin/sh
# Runs every test program in a build tree, the command-line and signal
# tests, the fuzzers' regressions, the POV-Ray parity suite and 40 random
# parity scenes, the stability set and, when given, the exact judge
# (EXACT_RAYS rays per case, default 1000000), then prints one closing line:
# "N passed, N failed".
#   scripts/run-tests.sh build/san [build/exact/judge]
set -u
dir=${1:-build/san}
judge=${2:-}
passed=0
failed=0
# run LABEL COMMAND...: runs one program and counts it
run() {
    label=$1
    shift
    echo "== $label"
    if "$@"; then passed=$((passed + 1)); else failed=$((failed + 1)); echo "FAILED: $label"; fi
}
for t in "$dir"/test_*; do
    [ -x "$t" ] || continue
    run "$t" "$t"
done
run tests/cli.sh sh tests/cli.sh "$dir/lancer"
run tests/signals.sh sh tests/signals.sh "$dir/lancer"
run tests/tiles.sh sh tests/tiles.sh "$dir/lancer"
# every input that ever failed a fuzzer, through its harness once more
for r in "$dir"/replay_*; do
    name=${r##*/replay_}
    set -- tests/fuzz/regressions/"$name"/*
    [ -e "$1" ] || continue
    run "$r tests/fuzz/regressions/$name ($# inputs)" "$r" "$@"
done
run tests/install.sh sh tests/install.sh
run scripts/check-links.sh sh scripts/check-links.sh
run scripts/parity.sh sh scripts/parity.sh "$dir/lancer"
run "scripts/parity.sh tests/parity" sh scripts/parity.sh "$dir/lancer" tests/parity/*.scn
run "scripts/parity-random.sh (40 scenes)" sh scripts/parity-random.sh "$dir/lancer" 40
run scripts/stability.sh sh scripts/stability.sh "$dir/lancer"
if [ -n "$judge" ]; then
    run "$judge ${EXACT_RAYS:-1000000}" "$judge" "${EXACT_RAYS:-1000000}"
fi
echo "programs: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
