#!/usr/bin/env bash
# Generates the data the shipped demo (config/demo.toml) runs on, from files in the repo:
#   <build>/demo/fighter.kdb   the fighter's motion database (content/motions/motions.toml)
#   <build>/demo/recording/    a SYNTHETIC tracking recording of a scripted visitor seen by
#                              the shipped 4-camera rig (config/rig/calibration.yaml)
# Usage: scripts/make-demo-data.sh [build-dir]     (called by scripts/setup.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${1:-build}
BIN="$BUILD_DIR/bin"
OUT="$BUILD_DIR/demo"
mkdir -p "$OUT"

echo "== fighter database -> $OUT/fighter.kdb"
"$BIN/kumite-motion" build --annotations content/motions/motions.toml --out "$OUT/fighter.kdb"

# The recording is regenerated only when missing or older than the rig or the tool.
if [[ ! -f "$OUT/recording/frames.csv" || config/rig/calibration.yaml -nt "$OUT/recording/frames.csv" \
      || "$BIN/kumite-track" -nt "$OUT/recording/frames.csv" ]]; then
  echo "== synthetic recording -> $OUT/recording (8 s, 4 cameras, 60 Hz)"
  rm -rf "$OUT/recording.tmp"
  "$BIN/kumite-track" synth --calibration config/rig/calibration.yaml --config config/tracking.toml \
    --out "$OUT/recording.tmp" --duration 8 --trajectory scripted --noise-px 0.3 --image-noise 0 \
    --seed 1
  rm -rf "$OUT/recording"
  mv "$OUT/recording.tmp" "$OUT/recording"
else
  echo "== synthetic recording up to date: $OUT/recording"
fi
