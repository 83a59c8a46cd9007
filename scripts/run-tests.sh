#!/bin/sh
# Runs every test program in a build tree, the command-line tests, the
# POV-Ray parity suite, the stability set and, when given, the exact judge
# (EXACT_RAYS rays per case, default 1000000), then prints one closing line:
# "N passed, N failed".
#   scripts/run-tests.sh build/san [build/exact/judge]
set -u
dir=${1:-build/san}
judge=${2:-}
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
echo "== scripts/stability.sh"
if sh scripts/stability.sh "$dir/lancer"; then passed=$((passed + 1)); else failed=$((failed + 1)); echo "FAILED: scripts/stability.sh"; fi
if [ -n "$judge" ]; then
    echo "== $judge ${EXACT_RAYS:-1000000}"
    if "$judge" "${EXACT_RAYS:-1000000}"; then passed=$((passed + 1)); else failed=$((failed + 1)); echo "FAILED: $judge"; fi
fi
echo "programs: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
