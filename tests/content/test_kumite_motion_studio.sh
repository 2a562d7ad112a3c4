#!/bin/sh
# The 240-strike grid on "another studio's" database (scripts/make-studio-data.sh: HDM05 kicks of
# five actors at 30 and 60 fps, the assimp boxer at 30 fps, resampled from the development mocap;
# tests only), each strike recorded at its clip's rate (30 or 60 Hz). At 30 Hz per-second limits
# applied per update (a * dt^2) let a foot's hold lift the whole body 5.9 cm in one frame (85 of
# 240 strikes snapped somewhere in their BVH, 46 over the frames compared with the source, whose
# clips have none). Usage: test_kumite_motion_studio.sh TOOL SOURCE_DIR
# PYTHON3 (exit 77: no mocap).
set -u
tool=$1
src=$2
python=$3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
bin=$(dirname "$tool")
bash "$src/scripts/make-studio-data.sh" "$work/content/motions" "$bin" >"$work/make.txt" 2>&1
rc=$?
[ $rc -eq 77 ] && { echo "skipped: no development mocap"; exit 77; }
[ $rc -eq 0 ] || fail "make-studio-data.sh exited $rc: $(cat "$work/make.txt")"
ln -s "$src/content/characters" "$work/content/characters"
ln -s "$src/content/dialects" "$work/content/dialects"
"$tool" build --annotations "$work/content/motions/motions.toml" --out "$work/studio.kdb" >/dev/null 2>"$work/err.txt" \
  || fail "build exited $?: $(tail -n 1 "$work/err.txt")"
KUMITE_CONTENT_DIR="$work/content" "$tool" quality --db "$work/studio.kdb" --out "$work/q.json" >"$work/q.txt" 2>&1 \
  || fail "quality exited $?: $(tail -n 1 "$work/q.txt")"
strikes=$(grep -c '"order":' "$work/q.json")
[ "$strikes" -eq 240 ] || fail "$strikes strikes in the grid, not 240"
src_snaps=$(sed -n 's/^ *"source_strikes_with_snaps": \([0-9]*\),*$/\1/p' "$work/q.json" | head -n 1)
[ "${src_snaps:-x}" = 0 ] || fail "the source clips snap over the compared frames (${src_snaps:-no figure}): not the fighter's"
# No one-frame jump of the whole body (pelvis) anywhere in any strike's BVH, none of a foot or any
# other joint over the frames compared with the source but a knee's (Known limits: a nearly straight
# leg's knee moves 2-3x a foot's or the pelvis's step).
"$python" - "$work/q.json" <<'PY' || fail "snaps: see above"
import json, sys
d = json.load(open(sys.argv[1]))
bad = []
for s in d["strikes"]:
    who = f'{s["character"]} {s["order"]} {s["segment"]}'
    for x in s["whole"].get("snap_list", []):
        if "(pelvis)" in x["joint"]:
            bad.append(f'{who}: pelvis {x["step_mm"]:.0f} mm at frame {x["frame"]}')
    for x in s["output"]["snap_list"]:
        if "knee)" not in x["joint"]:
            bad.append(f'{who}: {x["joint"]} {x["step_mm"]:.0f} mm at frame {x["frame"]}')
# And the knees: at most 3 strikes with a snap anywhere in their BVH, 2 over the compared frames
# (2 and 2 when written; 6 and 3 before the short-lift rule and the drop's need at coarse
# updates, 55 and 5 before the coarse-update bounds of content/README "Feet").
whole = sum(1 for s in d["strikes"] if s["whole"]["snaps"])
compared = sum(1 for s in d["strikes"] if s["output"]["snaps"])
if whole > 3 or compared > 2:
    bad.append(f"{whole} strikes snap in their BVH (at most 3), {compared} over the compared frames (at most 2)")
if bad:
    print(f"FAIL: {len(bad)} snaps: " + "; ".join(bad[:5]))
    sys.exit(1)
PY
echo "studio grid: 240 strikes, no whole-body jump, none over the compared frames but knees, at most 3 strikes with a knee snap"
