#!/bin/sh
# kumite-motion's outputs: a folder that does not exist is made before any work; one that cannot
# be made (under a file) is refused at once, in one line naming the option, with exit 1 and
# nothing written. Usage: test_kumite_motion_outputs.sh TOOL DATABASE
set -u
tool=$1
db=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work" || exit 1
fail() { echo "FAIL: $*"; exit 1; }
"$tool" build --annotations "$db" --out fighter.kdb >/dev/null 2>&1 || fail "could not build the database from $db"

: >afile
for cmd in "quality --db fighter.kdb --characters kenji --targets 1 --out afile/q.json" \
           "bout --db fighter.kdb --seconds 2 --out afile/b.bvh --report r.json" \
           "strike --db fighter.kdb --character kenji --order punch_right --target 0,1.5,0.8 --out s.bvh --report afile/s.json"; do
  # shellcheck disable=SC2086
  "$tool" $cmd >out.txt 2>err.txt; rc=$?
  [ $rc -eq 1 ] || fail "'$cmd' exited $rc (expected 1): $(cat err.txt)"
  [ "$(wc -l <err.txt)" -eq 1 ] || fail "'$cmd' did not give one line: $(cat err.txt)"
  grep -q "^kumite-motion: --\(out\|report\) afile/.*cannot create the folder" err.txt || fail "'$cmd': $(cat err.txt)"
done
{ [ -e r.json ] || [ -e s.bvh ]; } && fail "a refused run wrote its other output"

"$tool" quality --db fighter.kdb --characters kenji --targets 1 --out new/deeper/q.json >out.txt 2>err.txt \
  || fail "quality into a new folder exited $?: $(cat err.txt)"
[ -s new/deeper/q.json ] || fail "quality wrote no new/deeper/q.json"
echo "kumite-motion outputs: ok"
