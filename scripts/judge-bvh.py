#!/usr/bin/env python3
"""Judge a BVH as a viewer would, by a path independent of Kumite's C++ code.

Pure Python (no numpy): its own BVH parser and forward kinematics, then on the drawn joints:
  - snaps: a joint faster than 20 m/s, or a one-frame step > 5 cm and > 3x both neighbouring steps
  - flat feet: ankle and toe both within 1.5 cm of the floor's level for ankles / toes: the
    lowest those of both feet hold for 0.1 s in the file (a dip of a few frames, a blow's or a
    toe's, moves it not; a foot that never stands in the file does not make its own floor)
  - support-foot slide: horizontal speed over ~33 ms while the foot stands flat (max per file)
  - peak foot speed (any phase) and p99 joint speed
  - folded limbs: frames where an ankle or wrist is nearer its hip or shoulder than 0.1 of the
    limb's two bones (the least share of each limb, and where)
  - limb swings: frames where a knee or elbow standing at least 0.15 of its limb off the line
    from hip to ankle (shoulder to wrist) turns about that line faster than 2000 deg/s (the
    fastest of each limb, and where)
Foot joints are found by name (CMU: lfoot/ltoes, MotionBuilder: LeftFoot/LeftToeBase, ...).

  scripts/judge-bvh.py a.bvh [b.bvh ...] [--frames A:B] [--json]
Prints one JSON line per file with --json, else a short table.
"""
import json
import math
import sys


def parse_bvh(path):
    with open(path) as f:
        tokens = f.read().split()
    i = 0
    names, parents, offsets, channels = [], [], [], []
    stack = []
    end_site = False
    while tokens[i] != "MOTION":
        t = tokens[i]
        if t in ("ROOT", "JOINT"):
            names.append(tokens[i + 1])
            parents.append(stack[-1] if stack else -1)
            offsets.append((0.0, 0.0, 0.0))
            channels.append([])
            i += 2
        elif t == "End":
            end_site = True
            i += 2
        elif t == "{":
            stack.append(-2 if end_site else len(names) - 1)
            i += 1
        elif t == "}":
            stack.pop()
            end_site = False
            i += 1
        elif t == "OFFSET":
            if not end_site:
                offsets[-1] = tuple(float(x) for x in tokens[i + 1:i + 4])
            i += 4
        elif t == "CHANNELS":
            n = int(tokens[i + 1])
            channels[-1] = tokens[i + 2:i + 2 + n]
            i += 2 + n
        else:
            i += 1
    # Skip -2 (end site) parents: end sites have no joints here.
    i += 1
    assert tokens[i] == "Frames:"
    nframes = int(tokens[i + 1])
    assert tokens[i + 2] == "Frame" and tokens[i + 3] == "Time:"
    dt = float(tokens[i + 4])
    i += 5
    nch = sum(len(c) for c in channels)
    frames = []
    for _ in range(nframes):
        frames.append([float(x) for x in tokens[i:i + nch]])
        i += nch
    return names, parents, offsets, channels, dt, frames


def rot(axis, deg):
    a = math.radians(deg)
    c, s = math.cos(a), math.sin(a)
    if axis == "X":
        return ((1, 0, 0), (0, c, -s), (0, s, c))
    if axis == "Y":
        return ((c, 0, s), (0, 1, 0), (-s, 0, c))
    return ((c, -s, 0), (s, c, 0), (0, 0, 1))


def mul(a, b):
    return tuple(tuple(sum(a[r][k] * b[k][c] for k in range(3)) for c in range(3)) for r in range(3))


def apply(m, v):
    return tuple(sum(m[r][k] * v[k] for k in range(3)) for r in range(3))


def fk(names, parents, offsets, channels, frame):
    pos, rotm = [], []
    k = 0
    for j in range(len(names)):
        local_t = list(offsets[j])
        r = ((1, 0, 0), (0, 1, 0), (0, 0, 1))
        for ch in channels[j]:
            v = frame[k]
            k += 1
            if ch.endswith("position"):
                local_t["XYZ".index(ch[0])] = v
            else:
                r = mul(r, rot(ch[0], v))
        p = parents[j]
        if p < 0:
            pos.append(tuple(local_t))
            rotm.append(r)
        else:
            o = apply(rotm[p], offsets[j])
            pos.append(tuple(pos[p][a] + o[a] for a in range(3)))
            rotm.append(mul(rotm[p], r))
    return pos


WRIST_NAMES = {
    "left": ("lwrist", "LeftHand", "LeftWrist", "l_wrist", "left_wrist"),
    "right": ("rwrist", "RightHand", "RightWrist", "r_wrist", "right_wrist"),
}
FOLDED_SHARE = 0.1
# A knee or elbow turning about its limb's line (hip to ankle, shoulder to wrist) faster than
# SWING_DEG_S while at least SWING_OFF_SHARE of the limb off it: the mocap here turns them at
# most 1157 deg/s (a knee, HDM05 tr's front kick) and 1374 deg/s (an elbow, CMU 135_06), measured
# so at 100-120 fps (a limb nearly straight turns fast about its line and moves little: not counted).
SWING_DEG_S = 2000.0
SWING_OFF_SHARE = 0.15
FOOT_NAMES = {
    "left": (("lfoot", "LeftFoot", "LeftAnkle", "l_ankle", "left_ankle"), ("ltoes", "LeftToeBase", "LeftToes", "LeftToe", "l_toe")),
    "right": (("rfoot", "RightFoot", "RightAnkle", "r_ankle", "right_ankle"), ("rtoes", "RightToeBase", "RightToes", "RightToe", "r_toe")),
}


def find(names, options):
    for o in options:
        if o in names:
            return names.index(o)
    return -1


def guess_unit(pos0, names):
    ys = [p[1] for p in pos0]
    h = max(ys) - min(ys)
    return 0.01 if h > 10 else 1.0  # centimetres for human-sized files above 10 units


def dist(a, b):
    return math.sqrt(sum((a[i] - b[i]) ** 2 for i in range(3)))


def pct(v, p):
    if not v:
        return 0.0
    s = sorted(v)
    return s[min(len(s) - 1, int(p / 100 * (len(s) - 1)))]


def leg_length(names, parents, offsets, unit):
    """m: the leg's two bones from the file's own offsets (thigh + shin), mean of both sides."""
    legs = []
    for ank_names, _ in FOOT_NAMES.values():
        a = find(names, ank_names)
        if a >= 0 and parents[a] >= 0:
            k = parents[a]
            legs.append((math.sqrt(sum(c * c for c in offsets[a])) + math.sqrt(sum(c * c for c in offsets[k]))) * unit)
    return sum(legs) / len(legs) if legs else None


def lay_on_bones(P, parents, lengths, root_scale):
    """Each bone of the joint positions P (frames x joints, m) laid along its own direction at
    lengths[j] (m), the root's way scaled by root_scale: the same motion on another body."""
    out = []
    for fr in P:
        q = []
        for j, p in enumerate(parents):
            if p < 0:
                q.append(tuple(c * root_scale for c in fr[j]))
                continue
            d = [fr[j][a] - fr[p][a] for a in range(3)]
            n = math.sqrt(sum(c * c for c in d))
            u = [c / n for c in d] if n > 1e-9 else [0.0, 0.0, 0.0]
            q.append(tuple(q[p][a] + u[a] * lengths[j] for a in range(3)))
        out.append(q)
    return out


def judge(path, first=0, last=None, bones=None):
    """bones: another BVH (a character) with the same joints; the p99 joint speed is also given
    with this file's motion laid on its bones (p99_joint_speed_on_bones_mps)."""
    names, parents, offsets, channels, dt, frames = parse_bvh(path)
    frames = frames[first:last]
    P = [fk(names, parents, offsets, channels, f) for f in frames]
    unit = guess_unit(P[0], names)
    P = [[tuple(c * unit for c in p) for p in fr] for fr in P]
    n, J = len(P), len(names)
    on_bones = None
    if bones:
        bn, bp, bo, bc, _, bf = parse_bvh(bones)
        if bp == parents:
            bunit = guess_unit(fk(bn, bp, bo, bc, bf[0]), bn)
            own_leg, their_leg = leg_length(names, parents, offsets, unit), leg_length(bn, bp, bo, bunit)
            if own_leg and their_leg:
                L = lay_on_bones(P, parents, [math.sqrt(sum(c * c for c in o)) * bunit for o in bo], their_leg / own_leg)
                on_bones = [dist(L[i + 1][j], L[i][j]) / dt for j in range(J) for i in range(n - 1)]
    snaps = []
    speeds = []
    fastest = (0.0, "", 0)
    for j in range(J):
        steps = [dist(P[i + 1][j], P[i][j]) for i in range(n - 1)]
        for i, s in enumerate(steps):
            v = s / dt
            speeds.append(v)
            if v > fastest[0]:
                fastest = (v, names[j], i + 1)
            prev = steps[i - 1] if i > 0 else None
            nxt = steps[i + 1] if i + 1 < len(steps) else None
            jump = s > 0.05 and (prev is None or s > 3 * prev) and (nxt is None or s > 3 * nxt) and (prev is not None or nxt is not None)
            if v > 20 or jump:
                snaps.append((i + 1, names[j], round(s * 100, 1)))
    out = {"file": path, "frames": n, "dt": dt, "p99_joint_speed_mps": round(pct(speeds, 99), 3),
           "max_joint_speed_mps": round(fastest[0], 2), "fastest": f"{fastest[1]}@f{fastest[2]}",
           "snaps": len(snaps), "snap_list": snaps[:8]}
    # Body size: the leg's two bones from the file's own offsets (thigh + shin), in metres, to
    # compare speeds across bodies of different sizes (a joint moves faster on a longer limb).
    leg = leg_length(names, parents, offsets, unit)
    if leg:
        out["leg_m"] = round(leg, 4)
    if on_bones:
        out["p99_joint_speed_on_bones_mps"] = round(pct(on_bones, 99), 3)
    # Folded limbs: a limb's end (ankle, wrist) nearer its root (hip, shoulder) than
    # FOLDED_SHARE of the limb's two bones, a fold no body makes (the tightest in the mocap here:
    # the assimp boxer's knee, 0.14 of its leg; CMU 135's kicks 0.25; HDM05 picking up 0.27).
    folded, swing = {}, {}
    for side, names_ in WRIST_NAMES.items():
        for limb, end in (("leg", find(names, FOOT_NAMES[side][0])), ("arm", find(names, names_))):
            if end < 0 or parents[end] < 0 or parents[parents[end]] < 0:
                continue
            mid, root = parents[end], parents[parents[end]]
            length = dist(P[0][mid], P[0][root]) + dist(P[0][end], P[0][mid])
            if length <= 1e-6:
                continue
            shares = [dist(fr[end], fr[root]) / length for fr in P]
            k = min(range(n), key=lambda i: shares[i])
            folded[f"{side}_{limb}"] = {"min_share": round(shares[k], 3), "frame": k,
                                        "folded_frames": sum(1 for x in shares if x < FOLDED_SHARE)}
            # The middle joint's offset from the limb's line, frame to frame: how fast it turns.
            offs = []
            for fr in P:
                axis = [fr[end][c] - fr[root][c] for c in range(3)]
                a = math.sqrt(sum(c * c for c in axis))
                v = [fr[mid][c] - fr[root][c] for c in range(3)]
                if a <= 1e-9:
                    offs.append(None)
                    continue
                t = sum(v[c] * axis[c] for c in range(3)) / (a * a)
                o = [v[c] - t * axis[c] for c in range(3)]
                offs.append(o if math.sqrt(sum(c * c for c in o)) >= SWING_OFF_SHARE * length else None)
            fastest, at, over = 0.0, -1, 0
            for i in range(1, n):
                o0, o1 = offs[i - 1], offs[i]
                if o0 is None or o1 is None:
                    continue
                c = sum(o0[j] * o1[j] for j in range(3)) / math.sqrt(sum(x * x for x in o0) * sum(x * x for x in o1))
                speed = math.degrees(math.acos(max(-1.0, min(1.0, c)))) / dt
                over += speed > SWING_DEG_S
                if speed > fastest:
                    fastest, at = speed, i
            swing[f"{side}_{limb}"] = {"max_deg_s": round(fastest), "frame": at, "frames_over": over}
    out["folded_frames"] = sum(v["folded_frames"] for v in folded.values())
    out["folded"] = folded
    out["swing_frames"] = sum(v["frames_over"] for v in swing.values())
    out["swing"] = swing
    w = max(1, round(0.033 / dt))
    # The floor: the lowest level the ankles (and the toes) of both feet hold for 0.1 s.
    feet = [(find(names, a), find(names, t)) for a, t in FOOT_NAMES.values()]
    feet = [(a, t) for a, t in feet if a >= 0 and t >= 0]
    if not feet:  # no ankle and toe by any name it knows: no floor, no feet judged (said in the output)
        out["feet"] = "none found by name"
        return out
    amin = floor_level([fr[a][1] for a, _ in feet for fr in P], dt)
    tmin = floor_level([fr[t][1] for _, t in feet for fr in P], dt)
    for side, (ank_names, toe_names) in FOOT_NAMES.items():
        a, t = find(names, ank_names), find(names, toe_names)
        if a < 0 or t < 0:
            continue
        flat = [fr[a][1] < amin + 0.015 and fr[t][1] < tmin + 0.015 for fr in P]
        slide, peak = 0.0, 0.0
        for i in range(n - w):
            h = math.hypot(P[i + w][a][0] - P[i][a][0], P[i + w][a][2] - P[i][a][2]) / (w * dt)
            peak = max(peak, dist(P[i + w][a], P[i][a]) / (w * dt))
            if all(flat[i:i + w + 1]):
                slide = max(slide, h)
        out[f"{side}_flat_frames"] = sum(flat)
        out[f"{side}_support_slide_mps"] = round(slide, 3)
        out[f"{side}_peak_foot_speed_mps"] = round(peak, 2)
    return out


def floor_level(heights, dt):
    """The lowest height held for 0.1 s among `heights` (one joint kind of both feet over the
    file: the k-th lowest, k = 0.1 s of frames). A foot's own plain lowest moved with any single
    frame below the floor (a toe pushed under it once), and the file's flat-foot count with it;
    and a foot that never stood (a kick's, in a strike's window) had its lowest in the air."""
    k = max(1, round(0.1 / dt))
    lows = sorted(heights)
    return lows[min(k, len(lows)) - 1]


def main():
    args = sys.argv[1:]
    as_json = "--json" in args
    args = [a for a in args if a != "--json"]
    first, last = 0, None
    if "--frames" in args:
        k = args.index("--frames")
        a, b = args[k + 1].split(":")
        first, last = int(a or 0), (int(b) if b else None)
        del args[k:k + 2]
    for p in args:
        r = judge(p, first, last)
        if as_json:
            print(json.dumps(r))
        else:
            print(f"{p}: {r['frames']} frames, snaps {r['snaps']} {r['snap_list'][:3]}, p99 speed {r['p99_joint_speed_mps']} m/s, "
                  f"max {r['max_joint_speed_mps']} ({r['fastest']}), support slide L {r.get('left_support_slide_mps')} "
                  f"R {r.get('right_support_slide_mps')} m/s, foot peak L {r.get('left_peak_foot_speed_mps')} R {r.get('right_peak_foot_speed_mps')}, "
                  f"folded frames {r['folded_frames']}, limb swings over {SWING_DEG_S:.0f} deg/s {r['swing_frames']}")


if __name__ == "__main__":
    main()
