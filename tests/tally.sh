# tally.sh - sourced by the test scripts: the count of checks passed and
# failed, `ok` and `bad` to add to it, and `tally NAME`, the closing line
# "NAME: N passed, N failed", whose status fails if any check failed.
pass=0
fail=0
ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*"; }
tally() {
    echo "$1: $pass passed, $fail failed"
    [ "$fail" -eq 0 ]
}
