#!/usr/bin/env python3
"""scripts/judge-proximity.py on SYNTHETIC frames.jsonl lines whose truth is known by construction.

The visitor's head at (0, 1.6, 0), the left eye at (0, 1.5, 0); the fighter's four torso joints
all at one point per frame: 0.25 m to the visitor's side (x; near 0.25 m: under 0.3 only; its
pelvis 90 deg from straight ahead: 60-90), 0.15 m ahead (-z; under 0.3 and 0.2; 0 deg), 0.05 m
behind (+z; under all three; 180 deg: beyond 90), 0.8 m ahead (none; 0 deg), and a frame with no
fighter (skipped). Then a file with a `nan` head: one line naming the file and line, exit 1.
Usage: test-judge-proximity.py JUDGE (the path of scripts/judge-proximity.py)
"""
import json
import os
import subprocess
import sys
import tempfile

judge = sys.argv[1]
JOINTS = ("lowerback", "thorax", "upperneck", "head")


def frame(t, at, state, present=True):
    joints = {k: [at[0], 1.0 + 0.2 * i, at[1]] for i, k in enumerate(JOINTS)}
    return {"time_s": t, "head": {"position": [0, 1.6, 0]}, "eyes": {"left": [0, 1.5, 0], "right": [0.06, 1.5, 0]},
            "fighter": {"present": present, "state": state, "joints": joints if present else {}}}


failures = []
with tempfile.TemporaryDirectory() as d:
    good = os.path.join(d, "frames.jsonl")
    with open(good, "w") as f:
        for fr in (frame(0.0, (0.25, 0.0), "following"), frame(0.1, (0.0, -0.15), "recovering"),
                   frame(0.2, (0.0, 0.05), "recovering"), frame(0.3, (0.0, -0.8), "resting"),
                   frame(0.4, (0.0, 0.0), "resting", present=False)):
            f.write(json.dumps(fr) + "\n")
    r = subprocess.run([sys.executable, judge, good, "--json"], capture_output=True, text=True)
    if r.returncode != 0:
        failures.append(f"exit {r.returncode}: {r.stderr}")
    else:
        t = json.loads(r.stdout)["total"]
        want = {"frames": 4, "near_0.3": 3, "near_0.2": 2, "near_0.1": 1, "beyond_90_deg": 1, "from_60_to_90_deg": 1,
                "near_0.3_by_state": {"following": 1, "recovering": 2}}
        for k, v in want.items():
            if t.get(k) != v:
                failures.append(f"{k}: {t.get(k)}, want {v}")
        f0 = json.loads(r.stdout)["files"][0]
        if abs(f0["nearest_m"] - 0.05) > 1e-9 or f0["nearest_at_s"] != 0.2:
            failures.append(f"nearest {f0['nearest_m']} m at {f0['nearest_at_s']} s, want 0.05 at 0.2")
    bad = os.path.join(d, "bad.jsonl")
    with open(bad, "w") as f:
        f.write(json.dumps(frame(0.0, (0.25, 0.0), "resting")) + "\n")
        f.write(json.dumps(frame(0.1, (0.25, 0.0), "resting")).replace("[0, 1.6, 0]", "[NaN, 1.6, 0]") + "\n")
    r = subprocess.run([sys.executable, judge, bad], capture_output=True, text=True)
    lines = r.stderr.strip().splitlines()
    if r.returncode != 1 or len(lines) != 1 or f"{bad}:2:" not in lines[0]:
        failures.append(f"nan head: exit {r.returncode}, stderr {r.stderr!r}; want exit 1 and one line naming {bad}:2")
    else:
        print("nan head:", lines[0])

if failures:
    print("FAIL:\n  " + "\n  ".join(failures))
    sys.exit(1)
print("judge-proximity: 4 frames judged as constructed (near 3 / 2 / 1, bearing 1 beyond 90, 1 at 60-90), a nan refused")
