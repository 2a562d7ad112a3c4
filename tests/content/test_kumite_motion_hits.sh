#!/bin/sh
# Hit reactions as a viewer meets them (`kumite-motion hits`: SYNTHETIC blows into the sparring
# fighter): the fighter's BVH judged by scripts/judge-bvh.py (its own parser and forward
# kinematics): no snap, no support foot sliding beyond the bout's figure (1.0 m/s); and per blow,
# from the report: nothing drawn differently before the contact is judged, the struck point along
# the blow on the frame after it, the slow touch moving no joint, the punch under way aborted
# before its contact. Skipped (77) without the demo database. Usage:
# test_kumite_motion_hits.sh TOOL DB PYTHON3 JUDGE_BVH
set -u
tool=$1
db=$2
py=$3
judge=$4
[ -f "$db" ] || { echo "SKIP: no demo database $db (scripts/setup.sh makes it)"; exit 77; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work" || exit 1
fail() { echo "FAIL: $*"; exit 1; }
"$tool" hits --db "$db" --out hits.bvh --report hits.json >/dev/null 2>err.txt || fail "hits exited $?: $(cat err.txt)"
"$py" "$judge" hits.bvh --json >judge.json || fail "judge-bvh.py failed on hits.bvh"
"$py" - judge.json hits.json <<'PY' || exit 1
import json, sys
j = json.load(open(sys.argv[1]))
r = json.load(open(sys.argv[2]))
bad = []
if j["snaps"] != 0: bad.append(f"judge-bvh: {j['snaps']} snaps {j['snap_list']}")
for side in ("left", "right"):
    if j[f"{side}_support_slide_mps"] > 1.0: bad.append(f"judge-bvh: {side} support slide {j[side + '_support_slide_mps']} m/s")
for b in r["blows"]:
    if b["fist_speed_mps"] < 1.5:
        if b["visitor_hit_update"] != -1 or b["first_update_drawn_differently"] != -1 or b["largest_joint_difference_m"] != 0:
            bad.append(f"{b['label']}: the touch moved the fighter")
        continue
    if b["visitor_hit_update"] < 0: bad.append(f"{b['label']}: no visitor_hit"); continue
    if b["first_update_drawn_differently"] != b["visitor_hit_update"]:
        bad.append(f"{b['label']}: first drawn differently at {b['first_update_drawn_differently']}, contact judged at {b['visitor_hit_update']}")
    if not b["struck_point_along_blow_on_contact_frame_m"] > 0: bad.append(f"{b['label']}: the struck point does not move along the blow")
    if "own_punch_reached_contact" in b and b["own_punch_reached_contact"]: bad.append(f"{b['label']}: its own punch was not aborted")
if bad: print("FAIL: " + "; ".join(bad)); sys.exit(1)
print("hits: judged", len(r["blows"]), "blows; snaps 0")
PY
