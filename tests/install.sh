#!/bin/sh
# make install and make uninstall, into a temporary DESTDIR: the installed
# binary renders the default scene, the manual page renders with man -l
# without a warning and names every option of every command, and uninstall
# removes both files.
#   sh tests/install.sh        (from the repository's root)
# Prints "install: N passed, N failed" and fails if any check failed.
set -u
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
. "$(dirname "$0")/tally.sh"

dest="$T/stage"
bin="$dest/opt/lancer/bin/lancer"
page="$dest/opt/lancer/share/man/man1/lancer.1"
if make -s install DESTDIR="$dest" PREFIX=/opt/lancer >"$T/log" 2>&1; then ok; else bad "make install: $(tail -5 "$T/log")"; fi
[ -x "$bin" ] && ok || bad "no executable $bin"
[ -f "$page" ] && ok || bad "no manual page $page"

# the installed binary works on its own
if "$bin" render scenes/default.scn -o "$T/d.exr" --width 64 --height 48 -q && head -c 4 "$T/d.exr" | od -An -tx1 | grep -q "76 2f 31 01"; then
    ok
else
    bad "the installed lancer did not render the default scene"
fi
"$bin" --version | grep -q "^lancer [0-9]" && ok || bad "--version"

# the page renders without a warning
if MANWIDTH=80 man --warnings -l "$page" >"$T/page.txt" 2>"$T/warn" && [ ! -s "$T/warn" ] && [ -s "$T/page.txt" ]; then
    ok
else
    bad "man -l: $(head -5 "$T/warn")"
fi
# ... and names every option of every command's usage
for cmd in render tiles merge export-pov diff bench; do
    for opt in $("$bin" help "$cmd" | grep -o -- '--[a-z][a-z-]*' | sort -u); do
        if grep -qF -- "$opt" "$T/page.txt"; then ok; else bad "lancer.1 does not describe $cmd $opt"; fi
    done
done

if make -s uninstall DESTDIR="$dest" PREFIX=/opt/lancer >"$T/log" 2>&1; then ok; else bad "make uninstall"; fi
[ ! -e "$bin" ] && [ ! -e "$page" ] && ok || bad "uninstall left files behind"
tally install
