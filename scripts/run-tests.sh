#!/bin/sh
# Runs every test program in a build tree, the command-line tests and the
# POV-Ray parity suite, then prints one closing line: "N passed, N failed".
#   scripts/run-tests.sh build/san
set -u
dir=${1:-build/san}
passed=0
failed=0
for t in "$dir"/test_*; do
    [ -x "$t" ] || continue
    echo "== $t"
    if "$t"; then passed=$((passed + 1)); else failed=$((failed + 1)); echo "FAILED: $t"; fi
done
echo "== tests/cli.sh"
if sh tests/cli.sh "$dir/lancer"; then passed=$((passed + 1)); else failed=$((failed + 1)); echo "FAILED: tests/cli.sh"; fi
echo "== scripts/parity.sh"
if sh scripts/parity.sh "$dir/lancer"; then passed=$((passed + 1)); else failed=$((failed + 1)); echo "FAILED: scripts/parity.sh"; fi
echo "programs: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
