#!/usr/bin/env bash
# "Another studio's" mocap, for testing the fighter on clips it was not tuned on: the
# development set's HDM05 actors (five other bodies), the assimp boxer (another skeleton
# dialect, 100 fps) resampled to 30 and 60 fps with `kumite-motion resample` (rotations
# slerped, positions lerped), beside tests/content/data/studio/motions.toml (annotated on the
# resampled frames). TESTS ONLY: the boxer's licence is unclear (PROVENANCE.md section 2), so
# the output and any database built from it stay out of the shipped tree.
# Usage: scripts/make-studio-data.sh OUT_DIR [BIN_DIR]   (then kumite-motion build
#        --annotations OUT_DIR/motions.toml --out OUT_DIR/studio.kdb)
set -euo pipefail
OUT=$(realpath -m "${1:?usage: make-studio-data.sh OUT_DIR [BIN_DIR]}")
BIN=$(realpath -m "${2:-$(dirname "$0")/../build/bin}")
cd "$(dirname "$0")/.."
MOCAP=${KUMITE_MOCAP_DIR:-../shared/data/mocap}
[[ -d "$MOCAP/hdm05" ]] || { echo "no mocap at $MOCAP" >&2; exit 77; }
mkdir -p "$OUT"
# file (relative to the mocap folder) and the frame rate the "studio" delivered it at
while read -r rel fps; do
  [[ -z "$rel" || "$rel" == \#* ]] && continue
  stem=$(basename "$rel" .bvh)
  "$BIN/kumite-motion" resample "$MOCAP/$rel" --fps "$fps" --out "$OUT/${stem}_${fps}fps.bvh" >/dev/null
done < tests/content/data/studio/clips.txt
cp tests/content/data/studio/motions.toml "$OUT/motions.toml"
echo "wrote $OUT: $(ls "$OUT"/*.bvh | wc -l) clips and motions.toml"
