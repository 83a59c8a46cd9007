#!/bin/sh
# Installs the Debian packages lancer needs, or says how to.
#   scripts/deps.sh run    what building and rendering need
#   scripts/deps.sh test   that, plus what the tests need
#   scripts/deps.sh bench  that, plus Embree and gnuplot for the benchmarks
# As root it calls apt-get for whatever is missing; otherwise it prints the
# exact command to run and fails, so that nothing half-works.
set -eu

pkgs="gcc make pkg-config libc6-dev libopenexr-dev libpng-dev"
test_pkgs="libcmocka-dev povray g++ libcgal-dev libcgal-demo libgmp-dev libmpfr-dev man-db openexr openimageio-tools clang libclang-rt-14-dev slurm-wlm munge parallel"
case "${1:-run}" in
    run) ;;
    test) pkgs="$pkgs $test_pkgs" ;;
    bench) pkgs="$pkgs $test_pkgs libembree-dev gnuplot-nox" ;;
    *) echo "usage: scripts/deps.sh run|test|bench" >&2; exit 2 ;;
esac

missing=""
for p in $pkgs; do
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
        missing="$missing $p"
    fi
done
[ -z "$missing" ] && exit 0

if [ "$(id -u)" -eq 0 ]; then
    echo "deps: installing$missing" >&2
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    # shellcheck disable=SC2086
    apt-get install -y -qq --no-install-recommends $missing >/dev/null
else
    echo "deps: missing packages:$missing" >&2
    echo "deps: run: sudo apt-get install -y$missing" >&2
    exit 1
fi
