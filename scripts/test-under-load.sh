#!/usr/bin/env bash
# The test command N times in a row beside a CPU hog on every core (a busy loop per core, at
# the tests' own priority), to catch tests that hold only on a quiet machine.
#
#   scripts/test-under-load.sh [N] [BUILD_DIR] [extra ctest arguments...]
#   scripts/test-under-load.sh 10 build
#   ASAN_OPTIONS=... scripts/test-under-load.sh 3 build-asan -LE slow
#
# Prints one line per run (passed/failed, seconds, the failed tests) and exits non-zero if any
# run failed. The hog stops with the script (also on Ctrl-C).
set -uo pipefail
cd "$(dirname "$0")/.."
N=${1:-10}
BUILD_DIR=${2:-build}
shift $(( $# >= 2 ? 2 : $# ))
hogs=()
cleanup() { for p in "${hogs[@]}"; do kill "$p" 2>/dev/null; done; }
trap cleanup EXIT INT TERM
for _ in $(seq "$(nproc)"); do
  ( while :; do :; done ) &
  hogs+=($!)
done
failed_runs=0
for i in $(seq "$N"); do
  start=$(date +%s)
  log=$(mktemp)
  if ctest --test-dir "$BUILD_DIR" -j2 "$@" >"$log" 2>&1; then
    echo "run $i/$N: passed in $(( $(date +%s) - start )) s ($(grep -o '[0-9]*% tests passed, [0-9]* tests failed out of [0-9]*' "$log" | head -1))"
  else
    failed_runs=$((failed_runs + 1))
    echo "run $i/$N: FAILED in $(( $(date +%s) - start )) s: $(grep -E '^\s+[0-9]+ - ' "$log" | tr -s ' ' | tr '\n' ';')"
    cp "$log" "/tmp/test-under-load-run$i.log"
    echo "  (log: /tmp/test-under-load-run$i.log)"
  fi
  rm -f "$log"
done
echo "$((N - failed_runs)) passed, $failed_runs failed"
[[ $failed_runs == 0 ]]
