#!/bin/sh
# Checks the documentation's cross-references: every relative link in
# README.md and docs/*.md names a file of the repository, and a link to a
# section (file.md#anchor) names a heading of that file; and no tracked file
# points outside the repository, to its authors' notes beside it.
#   sh scripts/check-links.sh     (from the repository's root)
# Prints "links: N checked, N broken" and fails if any is broken.
set -u
checked=0
broken=0
bad() { broken=$((broken + 1)); echo "BROKEN: $*"; }

# slugs FILE: GitHub's anchor of each heading: lower case, punctuation but
# '-' and '_' dropped, blanks to '-'.
slugs() {
    sed -n 's/^#\{1,6\} \{1,\}//p' "$1" | tr 'A-Z' 'a-z' | sed 's/[^a-z0-9 _-]//g; s/ /-/g'
}

for f in README.md docs/*.md; do
    [ -f "$f" ] || continue
    dir=$(dirname "$f")
    # every ](target) outside code spans; a line may hold several
    grep -o '](\([^)]*\))' "$f" | sed 's/^](//; s/)$//' | while IFS= read -r target; do
        case "$target" in
        http://* | https://* | mailto:*) continue ;;
        esac
        path=${target%%#*}
        anchor=
        case "$target" in *'#'*) anchor=${target#*#} ;; esac
        file=$f
        [ -n "$path" ] && file="$dir/$path"
        if [ ! -e "$file" ]; then
            echo "BROKEN: $f: $target (no $file)"
            continue
        fi
        if [ -n "$anchor" ] && ! slugs "$file" | grep -qx -- "$anchor"; then
            echo "BROKEN: $f: $target (no heading '#$anchor' in $file)"
        fi
        echo "OK"
    done
done >"${TMPDIR:-/tmp}/lancer-links.$$"
checked=$(grep -c '^OK$' "${TMPDIR:-/tmp}/lancer-links.$$")
grep '^BROKEN' "${TMPDIR:-/tmp}/lancer-links.$$"
broken=$(grep -c '^BROKEN' "${TMPDIR:-/tmp}/lancer-links.$$")
rm -f "${TMPDIR:-/tmp}/lancer-links.$$"

# The repository stands alone: nothing refers to its authors' notes, the
# folder "shared" beside it and the reference file in it. The patterns are
# written as classes so that this file does not match them itself.
if git ls-files >/dev/null 2>&1; then
    hits=$(git grep --untracked -l -e '[.][.]/shared/' -e 'REFERENCE[.]md' -- . 2>/dev/null || true)
    for h in $hits; do
        broken=$((broken + 1))
        echo "BROKEN: $h refers to the authors' notes outside the repository"
    done
fi
echo "links: $checked checked, $broken broken"
[ "$broken" -eq 0 ]
