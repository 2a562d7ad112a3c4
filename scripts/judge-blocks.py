#!/usr/bin/env python3
"""Judge the fighter's blocks as the visitor meets them, by a path independent of Kumite's C++.

Reads what `kumite-recognise defend --out DIR` wrote: per recording the fighter's BVH (its drawn
skeleton: forward kinematics here, by judge-bvh.py's own parser) and a trace holding the
visitor's tracked wrists and ankles per fighter frame (the input the fighter was given) and the
labelled punches. Per labelled punch:
  - arrival: the first frame whose fist step (previous frame -> this) passes within fist + body
    radius of the drawn fighter's head (sphere) or torso (neck -> pelvis capsule); without one
    the punch never reaches the fighter (out of reach) and the frame of its nearest approach is used;
    in_reach_with_shoulders also counts a fist reaching the line between the shoulder joints
    (capsule r 0.07 m): a punch landing on a shoulder, beside the thin neck -> pelvis capsule
  - blocked: the fist step of some frame up to the arrival passes within fist + forearm radius of
    a drawn forearm (elbow -> wrist): the forearm is across the fist's path before the fist is
    at the body
Negative recordings (no strike): the frames the fighter reports blocking (its trace's `action`, its
own word) give the phantom defences per minute; phantom_blocks_after_onset leaves out those that
start within 0.2 s of the recording's first moving frame (the SYNTHETIC lead-in holds the first
pose still, and a clip that begins mid-motion jumps from it to full speed in one frame unless
`kumite-recognise defend --ease-in S` eases it in: the trace's ease_in_s). Independent of the
fighter's word, phantom_arm_moves counts on the same recordings the moments a drawn wrist starts
moving faster than 2 m/s relative to the drawn neck (forward kinematics of the BVH: the defence
runs without attacks or counters, so a fast arm is a parry; its parries move the wrist at 2.9-3.5
m/s there, the guard and the rest motion under 1.4 m/s).

  scripts/judge-blocks.py DIR [--json OUT]
"""
import importlib.util
import json
import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
spec = importlib.util.spec_from_file_location("judge_bvh", os.path.join(HERE, "judge-bvh.py"))
jb = importlib.util.module_from_spec(spec)
spec.loader.exec_module(jb)

FIST_R = 0.05      # m, a glove round the tracked wrist
FOREARM_R = 0.05   # m
HEAD_R = 0.12      # m
TORSO_R = 0.15     # m
ONSET_S = 0.2      # s after the lead-in (phantom_blocks_after_onset)
SHOULDER_R = 0.07  # m, the line between the shoulder joints (in_reach_with_shoulders only)
ARM_MOVE_MPS = 2.0  # m/s, a drawn wrist relative to the drawn neck (phantom_arm_moves)

NAMES = {
    "head": ("head", "Head"),
    "neck": ("lowerneck", "Neck", "neck"),
    "pelvis": ("root", "Hips", "hips", "pelvis"),
    "l_shoulder": ("lhumerus", "LeftArm", "l_shoulder"),
    "r_shoulder": ("rhumerus", "RightArm", "r_shoulder"),
    "l_elbow": ("lradius", "LeftForeArm", "l_elbow"),
    "l_wrist": ("lwrist", "LeftHand", "l_wrist"),
    "r_elbow": ("rradius", "RightForeArm", "r_elbow"),
    "r_wrist": ("rwrist", "RightHand", "r_wrist"),
}


def seg_point(p, a, b):
    ab = [b[i] - a[i] for i in range(3)]
    l2 = sum(x * x for x in ab)
    s = 0.0 if l2 < 1e-12 else max(0.0, min(1.0, sum((p[i] - a[i]) * ab[i] for i in range(3)) / l2))
    return math.dist(p, [a[i] + s * ab[i] for i in range(3)])


def seg_seg(a0, a1, b0, b1, steps=40):
    return min(seg_point([a0[i] + (a1[i] - a0[i]) * k / steps for i in range(3)], b0, b1) for k in range(steps + 1))


def drawn_joints(path):
    names, parents, offsets, channels, _dt, frames = jb.parse_bvh(path)
    idx = {}
    for key, opts in NAMES.items():
        i = jb.find(names, opts)
        if i < 0:
            raise SystemExit(f"{path}: no joint for {key} (looked for {', '.join(opts)})")
        idx[key] = i
    out = []
    unit = None
    for fr in frames:
        pos = jb.fk(names, parents, offsets, channels, fr)
        if unit is None:
            unit = jb.guess_unit(pos, names)
        out.append({k: [c * unit for c in pos[i]] for k, i in idx.items()})
    return out


def judge_recording(folder, trace):
    body = drawn_joints(os.path.join(folder, trace["fighter_bvh"]))
    frames = trace["frames"]
    order = trace["limb_order"]
    dt = trace["dt_s"]
    out = []
    for s in trace["strikes"]:
        li = order.index(s["limb"])
        first, last = s["first"], min(s["last"], len(frames) - 1, len(body) - 1)
        arrival, nearest, nearest_d = None, None, 1e9
        reaches_shoulders = False
        for k in range(max(first, 1), last + 1):
            a, b = frames[k - 1]["limbs"][li][:3], frames[k]["limbs"][li][:3]
            j = body[k]
            d_head = seg_seg(a, b, j["head"], j["head"]) - HEAD_R
            d_torso = seg_seg(a, b, j["neck"], j["pelvis"]) - TORSO_R
            d = min(d_head, d_torso) - FIST_R
            if seg_seg(a, b, j["l_shoulder"], j["r_shoulder"]) - SHOULDER_R - FIST_R <= 0:
                reaches_shoulders = True
            if d < nearest_d:
                nearest, nearest_d = k, d
            if d <= 0:
                arrival = k
                break
        end = arrival if arrival is not None else nearest
        blocked_at = None
        for k in range(max(first, 1), (end or first) + 1):
            a, b = frames[k - 1]["limbs"][li][:3], frames[k]["limbs"][li][:3]
            j = body[k]
            for side in ("l", "r"):
                if seg_seg(a, b, j[side + "_elbow"], j[side + "_wrist"]) <= FIST_R + FOREARM_R:
                    blocked_at = k
                    break
            if blocked_at is not None:
                break
        out.append({
            "punch": s["name"], "limb": s["limb"], "in_reach": arrival is not None,
            "in_reach_with_shoulders": arrival is not None or reaches_shoulders,
            "arrival_frame": arrival, "nearest_gap_m": round(nearest_d, 3),
            "blocked": blocked_at is not None, "blocked_frame": blocked_at,
            "blocked_before_arrival_s": None if blocked_at is None or end is None else round((end - blocked_at) * dt, 3),
        })
    return out


def wrist_steps(body, first):
    """(frame, metres) from `first` on: the larger of the two drawn wrists' moves relative to the
    drawn neck since the frame before."""
    out = []
    for k in range(max(first, 1), len(body)):
        step = 0.0
        for side in ("l", "r"):
            now = [body[k][side + "_wrist"][i] - body[k]["neck"][i] for i in range(3)]
            before = [body[k - 1][side + "_wrist"][i] - body[k - 1]["neck"][i] for i in range(3)]
            step = max(step, math.dist(now, before))
        out.append((k, step))
    return out


def main():
    args = sys.argv[1:]
    if not args or args[0].startswith("-"):
        print(__doc__)
        return 2
    folder = args[0]
    out_json = args[args.index("--json") + 1] if "--json" in args else None
    punches, negatives_s, phantom, phantom_after_onset, ease_in, arm_moves = [], 0.0, 0, 0, [], 0
    per_negative = []
    for name in sorted(os.listdir(folder)):
        if not name.endswith(".trace.json"):
            continue
        with open(os.path.join(folder, name)) as f:
            trace = json.load(f)
        ease_in.append(trace.get("ease_in_s", 0.0))
        if trace["negative"]:
            frames = trace["frames"]
            lead = int(round(trace["lead_in_s"] / trace["dt_s"]))
            starts = [k for k in range(max(lead, 1), len(frames))
                      if frames[k]["action"] == "blocking" and frames[k - 1]["action"] != "blocking"]
            secs = (len(frames) - lead) * trace["dt_s"]
            negatives_s += secs
            phantom += len(starts)
            onset = lead + int(round(ONSET_S / trace["dt_s"]))
            phantom_after_onset += sum(1 for k in starts if k >= onset)
            body = drawn_joints(os.path.join(folder, trace["fighter_bvh"]))
            moves, fast_before = [], False
            for k, step in wrist_steps(body, lead):
                fast = step / trace["dt_s"] > ARM_MOVE_MPS
                if fast and not fast_before:
                    moves.append(k)
                fast_before = fast
            arm_moves += len(moves)
            per_negative.append({"recording": trace["recording"], "seconds": round(secs, 2), "blocks": len(starts),
                                 "block_starts_s": [round((k - lead) * trace["dt_s"], 3) for k in starts],
                                 "arm_move_starts_s": [round((k - lead) * trace["dt_s"], 3) for k in moves]})
            continue
        for p in judge_recording(folder, trace):
            p["recording"] = trace["recording"]
            punches.append(p)
    n = len(punches)
    summary = {
        "punches": n,
        "blocked_before_arrival": sum(p["blocked"] for p in punches),
        "blocked_share": round(sum(p["blocked"] for p in punches) / n, 3) if n else None,
        "in_reach_share": round(sum(p["in_reach"] for p in punches) / n, 3) if n else None,
        "in_reach_with_shoulders_share": round(sum(p["in_reach_with_shoulders"] for p in punches) / n, 3) if n else None,
        "negative_minutes": round(negatives_s / 60, 3),
        "phantom_blocks": phantom,
        "phantom_per_minute": round(phantom / (negatives_s / 60), 2) if negatives_s else None,
        "phantom_note": "block starts the fighter reports (its trace's action) on strike-free recordings",
        "phantom_arm_moves": arm_moves,
        "phantom_arm_moves_per_minute": round(arm_moves / (negatives_s / 60), 2) if negatives_s else None,
        "phantom_arm_moves_note": f"from the drawn joints alone: a wrist starting to move over {ARM_MOVE_MPS} m/s "
                                  "relative to the neck on a strike-free recording",
        "phantom_blocks_after_onset": phantom_after_onset,
        "phantom_after_onset_note": f"those starting {ONSET_S} s or more after the recording's first moving frame: "
                                    "a clip that begins mid-motion jumps from the still lead-in pose to full speed "
                                    "(unless eased in: ease_in_s)",
        "ease_in_s": sorted({t for t in ease_in}),
    }
    for p in punches:
        print(f"{p['recording']:34s} {p['punch']:34s} reach={'y' if p['in_reach'] else 'n'}{'' if p['in_reach'] == p['in_reach_with_shoulders'] else '(shoulder)'} "
              f"blocked={'y' if p['blocked'] else 'n'} before={p['blocked_before_arrival_s']} gap={p['nearest_gap_m']}")
    print(json.dumps(summary, indent=2))
    if out_json:
        tmp = out_json + ".tmp"
        with open(tmp, "w") as f:
            json.dump({"summary": summary, "punches": punches, "negatives": per_negative}, f, indent=2)
        os.replace(tmp, out_json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
