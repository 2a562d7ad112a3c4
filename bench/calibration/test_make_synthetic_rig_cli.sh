#!/bin/sh
# kumite_make_synthetic_rig's command line: --help prints usage and writes nothing; bad
# arguments are one line on stderr and exit 1, before anything is written; a folder under a
# file is refused in one line. Usage: test_make_synthetic_rig_cli.sh TOOL
set -u
tool=$1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work" || exit 1
fail() { echo "FAIL: $*"; exit 1; }

"$tool" --help >help.txt 2>&1 || fail "--help exited $?"
grep -q "Usage:" help.txt || fail "--help printed no usage: $(cat help.txt)"
[ -e ./--help ] && fail "--help wrote a folder named --help"

"$tool" out abc >out.txt 2>err.txt; rc=$?
[ $rc -eq 1 ] || fail "'out abc' exited $rc (expected 1): $(cat err.txt)"
[ "$(wc -l <err.txt)" -eq 1 ] || fail "'out abc' did not give one line: $(cat err.txt)"
grep -q "^kumite_make_synthetic_rig: .*abc" err.txt || fail "'out abc': $(cat err.txt)"
[ -e out ] && fail "'out abc' wrote out/"

"$tool" out 0 >out.txt 2>err.txt; rc=$?
[ $rc -eq 1 ] || fail "'out 0' exited $rc"
[ "$(wc -l <err.txt)" -eq 1 ] || fail "'out 0' did not give one line: $(cat err.txt)"

"$tool" >out.txt 2>err.txt; rc=$?
[ $rc -eq 1 ] || fail "no arguments exited $rc"
grep -q "^kumite_make_synthetic_rig: .*out" err.txt || fail "no arguments: $(cat err.txt)"

: >afile
"$tool" afile/set 1 >out.txt 2>err.txt; rc=$?
[ $rc -eq 1 ] || fail "'afile/set' exited $rc"
[ "$(cat err.txt)" = "kumite_make_synthetic_rig: afile/set: cannot create the folder: afile is a file, not a folder" ] ||
  fail "'afile/set': $(cat err.txt)"
echo "ok"
