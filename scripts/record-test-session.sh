#!/usr/bin/env bash
# Re-records tests/app/data/session-demo, the short session tests/app_core/test_recorded_session.cpp
# replays bit for bit: 200 frames (3.3 s) of the shipped demo (config/demo.toml with its
# recording streamed rather than preloaded, so the head is tracked from the first second),
# headless at 64x36, no PNGs, the tracker on the synthetic demo recording, the demo's orders.
#
# Run it after a change that is MEANT to alter what the installation does (the fighter's motion
# in content/, the frame in app/), then commit tests/app/data/session-demo:
#
#   scripts/record-test-session.sh [BUILD_DIR]      # default build/
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${1:-build}
OUT=tests/app/data/session-demo
FRAMES=${FRAMES:-200}

nice cmake --build "$BUILD_DIR" --target kumite kumite-motion kumite-track -j"$(nproc)"
# The database from the motions as they are now (the recording only when stale).
scripts/make-demo-data.sh "$BUILD_DIR" >/dev/null

CFG=config/.record-test-session.toml   # beside demo.toml: its relative paths stay right
TMP=$(mktemp -d)
trap 'rm -f "$CFG"; rm -rf "$TMP"' EXIT
sed -e 's/^recording_preload = .*/recording_preload = 0            # streamed: the head tracked at once/' \
    config/demo.toml > "$CFG"
grep -q '^recording_preload = 0' "$CFG" || { echo "record-test-session: config/demo.toml has no recording_preload line" >&2; exit 1; }

"$BUILD_DIR/bin/kumite" --config "$CFG" --data-dir "$BUILD_DIR/demo" --headless --frames "$FRAMES" \
  --resolution 64x36 --save-every 0 --out "$TMP/out" --record "$TMP/session" -v 0
# It must replay identically here before it replaces the one in the repository.
"$BUILD_DIR/bin/kumite" --replay "$TMP/session" --data-dir "$BUILD_DIR/demo" -v 1
tracked=$(grep -c '"status":1,' "$TMP/session/session.jsonl" || true)
echo "record-test-session: $FRAMES frames, $tracked with the head tracked, $(du -sk "$TMP/session" | cut -f1) kB"
if (( tracked < FRAMES / 2 )); then  # the test asks for at least half (a busy machine skips sets)
  echo "record-test-session: the head was tracked in only $tracked of $FRAMES frames: the machine too busy? run it again" >&2
  exit 1
fi
rm -rf "$OUT"
mkdir -p "$(dirname "$OUT")"
mv "$TMP/session" "$OUT"
echo "record-test-session: -> $OUT (commit it)"
