#!/usr/bin/env python3
"""Where the drawn fighter stands against the visitor, from frames.jsonl, by a path independent
of Kumite's C++ (the joints the walls draw and the tracked head the run took as input).

Per frame:
  - near: the horizontal distance from the visitor's body axis (the vertical line through the
    tracked head, `head.position`) to the nearest of the fighter's drawn torso joints (lowerback,
    thorax, upperneck, head: `fighter.joints`). Under 0.3 m the two bodies overlap (a visitor's
    body ~0.2 m about that axis, the fighter's torso ~0.1 m about its joints); counted under
    0.3 / 0.2 / 0.1 m, and under 0.3 m by the fighter's state (`fighter.state`).
  - bearing: the angle of the drawn pelvis (lowerback) from straight ahead of the left eye
    (`eyes.left`; straight ahead is -Z, the front wall): frames over 90 deg (beside or behind the
    visitor, where no wall before them shows it) and 60-90 deg.
Frames without a fighter (`fighter.present` false) or without its joints are skipped.

  scripts/judge-proximity.py FRAMES.jsonl [FRAMES.jsonl ...] [--json]

Prints one line per file and a total (or, with --json, one JSON object: per file and total).
Exit 1 with one line naming the file and line on input it cannot read.
"""
import json
import math
import sys

TORSO = ("lowerback", "thorax", "upperneck", "head")
RADII = (0.3, 0.2, 0.1)


def judge(path):
    out = {"file": path, "frames": 0, "near_0.3": 0, "near_0.2": 0, "near_0.1": 0, "near_0.3_by_state": {},
           "beyond_90_deg": 0, "from_60_to_90_deg": 0, "nearest_m": None, "nearest_at_s": None}
    with open(path) as f:
        for n, line in enumerate(f, 1):
            try:
                j = json.loads(line)
                fighter = j.get("fighter") or {}
                joints = fighter.get("joints")
                if not joints or fighter.get("present") is False:
                    continue
                head = j["head"]["position"]
                eye = j["eyes"]["left"]
                near = min(math.hypot(joints[k][0] - head[0], joints[k][2] - head[2]) for k in TORSO)
                pelvis = joints["lowerback"]
                bearing = abs(math.degrees(math.atan2(pelvis[0] - eye[0], -(pelvis[2] - eye[2]))))
                values = [near, bearing, *head, *eye, *pelvis]
            except (KeyError, IndexError, TypeError, ValueError) as e:
                raise SystemExit(f"{path}:{n}: not a frame with fighter joints, head and eyes ({type(e).__name__}: {e})")
            if not all(math.isfinite(v) for v in values):
                raise SystemExit(f"{path}:{n}: a position that is not finite")
            out["frames"] += 1
            for r in RADII:
                out[f"near_{r}"] += near < r
            if near < 0.3:
                state = str(fighter.get("state", "?"))
                out["near_0.3_by_state"][state] = out["near_0.3_by_state"].get(state, 0) + 1
            out["beyond_90_deg"] += bearing > 90
            out["from_60_to_90_deg"] += 60 < bearing <= 90
            if out["nearest_m"] is None or near < out["nearest_m"]:
                out["nearest_m"], out["nearest_at_s"] = round(near, 3), j.get("time_s")
    return out


def main():
    args = sys.argv[1:]
    as_json = "--json" in args
    files = [a for a in args if a != "--json"]
    if not files:
        raise SystemExit("usage: judge-proximity.py FRAMES.jsonl [FRAMES.jsonl ...] [--json]")
    results = []
    for p in files:
        try:
            results.append(judge(p))
        except OSError as e:
            raise SystemExit(f"{p}: {e.strerror}")
    total = {"frames": 0, "beyond_90_deg": 0, "from_60_to_90_deg": 0, "near_0.3_by_state": {}}
    for r in RADII:
        total[f"near_{r}"] = 0
    for r in results:
        for k, v in r.items():
            if k in total and isinstance(v, int):
                total[k] += v
        for s, v in r["near_0.3_by_state"].items():
            total["near_0.3_by_state"][s] = total["near_0.3_by_state"].get(s, 0) + v
    if as_json:
        print(json.dumps({"files": results, "total": total}, indent=1))
        return
    for r in results + [dict(total, file="total")]:
        line = (f"{r['file']}: {r['frames']} frames; torso within 0.3 / 0.2 / 0.1 m of the visitor's axis "
                f"{r['near_0.3']} / {r['near_0.2']} / {r['near_0.1']}")
        if r.get("nearest_m") is not None:
            line += f" (nearest {r['nearest_m']} m at {r['nearest_at_s']} s)"
        states = ", ".join(f"{s} {v}" for s, v in sorted(r["near_0.3_by_state"].items(), key=lambda kv: -kv[1]))
        line += f" [{states or 'none'}]; pelvis > 90 / 60-90 deg from straight ahead {r['beyond_90_deg']} / {r['from_60_to_90_deg']}"
        print(line)


if __name__ == "__main__":
    main()
