#!/usr/bin/env python3
"""Forearm figures of a BVH clip, for reviewing block annotations in content/motions/motions.toml.

Parses the BVH, runs forward kinematics (no dependencies beyond the standard library) and, per
arm, reports where the forearm (elbow -> wrist) is: wrist and elbow heights above the floor as
fractions of the actor's stature, the forearm's angle from horizontal (0 = level, 90 = upright,
negative = wrist below elbow), the wrist's position in the pelvis' ground frame (forward, left,
as fractions of stature) and the wrist's speed.

Heights count from the clip's floor (the lowest ankle or toe over the clip) and stature is the
rest pose's height (lowest to highest joint), as kumite's annotation proposer measures them.

Two modes:

  scripts/forearm-trace.py content/motions/135_06.bvh --holds
      lists the "holds": a wrist that swept fast (>= --min-speed m/s) and then came nearly to
      rest (<= --hold-speed m/s) for at least --min-hold-s, with the figures at the hold's first
      frame. A block ends in such a hold (the forearm in place); punches end in one too, so read
      the figures: age-uke holds the wrist above the head (~1.0 of stature) with the forearm
      near horizontal; shuto-uke the wrist near the shoulder (0.75..0.9) with the forearm
      upright (> 45 deg); gedan-barai the wrist low (< 0.65) with the forearm pointing down.

  scripts/forearm-trace.py content/motions/135_06.bvh --frames 2300 2400 --step 5 [--arm left]
      prints the figures frame by frame.

  scripts/forearm-trace.py content/motions/135_06.bvh --block 1100 1200 --arm right
      summarises one block annotation: the sweep's peak wrist speed, then the intercept window
      (from where the wrist first comes to a stop after the peak, while it stays within --place
      of that point; it may run past the segment's end, which is then said) and the figures at
      its first frame (the intercept frame) and over it.

Only joints named as in CMU's ASF conversion (lhumerus, lradius, lwrist, ...) are known; other
dialects: map them with --joints elbow_l,wrist_l,elbow_r,wrist_r,pelvis,lhip,rhip.
"""
import argparse
import math
import sys


def parse_bvh(path):
    with open(path) as f:
        tokens = f.read().split()
    i = 0
    joints = []  # dicts: name, parent, offset, channels
    stack = []
    while tokens[i] != "MOTION":
        t = tokens[i]
        if t in ("ROOT", "JOINT"):
            joints.append({"name": tokens[i + 1], "parent": stack[-1] if stack else -1, "offset": None, "channels": []})
            i += 2
        elif t == "End":
            joints.append({"name": joints[stack[-1]]["name"] + "_end", "parent": stack[-1], "offset": None, "channels": []})
            i += 2
        elif t == "{":
            stack.append(len(joints) - 1)
            i += 1
        elif t == "}":
            stack.pop()
            i += 1
        elif t == "OFFSET":
            joints[stack[-1]]["offset"] = [float(x) for x in tokens[i + 1:i + 4]]
            i += 4
        elif t == "CHANNELS":
            n = int(tokens[i + 1])
            joints[stack[-1]]["channels"] = tokens[i + 2:i + 2 + n]
            i += 2 + n
        else:
            i += 1
    nframes = int(tokens[i + 2])
    dt = float(tokens[i + 5])
    i += 6
    width = sum(len(j["channels"]) for j in joints)
    values = [float(x) for x in tokens[i:i + nframes * width]]
    frames = [values[k * width:(k + 1) * width] for k in range(nframes)]
    return joints, frames, dt


def mat_mul(a, b):
    return [[sum(a[r][k] * b[k][c] for k in range(3)) for c in range(3)] for r in range(3)]


def rot(axis, deg):
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    if axis == "X":
        return [[1, 0, 0], [0, c, -s], [0, s, c]]
    if axis == "Y":
        return [[c, 0, s], [0, 1, 0], [-s, 0, c]]
    return [[c, -s, 0], [s, c, 0], [0, 0, 1]]


def apply(m, v):
    return [sum(m[r][k] * v[k] for k in range(3)) for r in range(3)]


def fk(joints, values):
    """World positions of every joint for one frame (values None: the rest pose)."""
    pos, rots = [], []
    k = 0
    for j in joints:
        local = [list(r) for r in ((1, 0, 0), (0, 1, 0), (0, 0, 1))]
        trans = list(j["offset"])
        for ch in j["channels"]:
            v = values[k] if values is not None else 0.0
            k += 1
            if ch.endswith("position"):
                if values is not None:
                    trans["XYZ".index(ch[0])] = v if j["parent"] < 0 else trans["XYZ".index(ch[0])] + v
            else:
                local = mat_mul(local, rot(ch[0], v))
        if j["parent"] < 0:
            pos.append(trans)
            rots.append(local)
        else:
            pr = rots[j["parent"]]
            p = apply(pr, trans)
            pos.append([pos[j["parent"]][a] + p[a] for a in range(3)])
            rots.append(mat_mul(pr, local))
    return pos


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("bvh")
    ap.add_argument("--frames", nargs=2, type=int, metavar=("FIRST", "LAST"))
    ap.add_argument("--step", type=int, default=1)
    ap.add_argument("--arm", choices=("left", "right", "both"), default="both")
    ap.add_argument("--holds", action="store_true", help="list the wrist holds after fast sweeps")
    ap.add_argument("--block", nargs=2, type=int, metavar=("FIRST", "LAST"), help="summarise one block segment")
    ap.add_argument("--min-speed", type=float, default=2.5, help="m/s: a sweep's peak wrist speed")
    ap.add_argument("--hold-speed", type=float, default=0.5, help="m/s: a hold's wrist speed")
    ap.add_argument("--min-hold-s", type=float, default=0.08)
    ap.add_argument("--place", type=float, default=0.03,
                    help="--block: the forearm is in place while the wrist stays this close (fraction of stature) to where it arrived")
    ap.add_argument("--unit-m", type=float, default=0.01, help="metres per BVH unit (content/motions: centimetres)")
    ap.add_argument("--joints", default="lradius,lwrist,rradius,rwrist,root,lfemur,rfemur")
    a = ap.parse_args()

    joints, frames, dt = parse_bvh(a.bvh)
    names = [j["name"] for j in joints]
    el, wl, er, wr, pel, lh, rh = (names.index(n) for n in a.joints.split(","))
    rest = fk(joints, None)
    stature = max(p[1] for p in rest) - min(p[1] for p in rest)
    feet = [i for i, n in enumerate(names) if any(w in n for w in ("foot", "toes"))]
    all_pos = [fk(joints, f) for f in frames]
    floor = min(p[i][1] for p in all_pos for i in feet)
    unit_m = a.unit_m

    def ground(p):
        """Forward (unit, on the floor) and left of the pelvis, from the hips."""
        hx = [p[lh][0] - p[rh][0], 0.0, p[lh][2] - p[rh][2]]  # right -> left
        n = math.hypot(hx[0], hx[2]) or 1.0
        left = [hx[0] / n, 0.0, hx[2] / n]
        fwd = [-left[2], 0.0, left[0]]  # left turned -90 deg about +Y
        return fwd, left

    def figures(f, side):
        p = all_pos[f]
        e, w = (el, wl) if side == "left" else (er, wr)
        d = [p[w][k] - p[e][k] for k in range(3)]
        ang = math.degrees(math.atan2(d[1], math.hypot(d[0], d[2])))
        fwd, left = ground(p)
        rel = [p[w][k] - p[pel][k] for k in range(3)]
        f0, f1 = max(0, f - 1), min(len(frames) - 1, f + 1)
        sp = math.dist(all_pos[f1][w], all_pos[f0][w]) * unit_m / ((f1 - f0) * dt)
        return {
            "wrist": (p[w][1] - floor) / stature,
            "elbow": (p[e][1] - floor) / stature,
            "angle": ang,
            "fwd": (rel[0] * fwd[0] + rel[2] * fwd[2]) / stature,
            "left": (rel[0] * left[0] + rel[2] * left[2]) / stature,
            "speed": sp,
        }

    sides = ("left", "right") if a.arm == "both" else (a.arm,)
    fmt = "f{:5d} {:5s} wrist {:.2f} elbow {:.2f} forearm {:+4.0f} deg  wrist fwd {:+.2f} left {:+.2f}  {:.1f} m/s"
    print(f"# {a.bvh}: {len(frames)} frames at {1 / dt:.0f} Hz, stature {stature * unit_m:.2f} m (heights, fwd, left: fractions of it)")
    if a.block:
        first, last = a.block
        for side in sides:
            end = min(len(frames) - 1, last + round(0.5 / dt))  # the hold may outlast the segment
            fig = {f: figures(f, side) for f in range(first, end + 1)}
            w = wl if side == "left" else wr
            peak = max(range(first, last + 1), key=lambda f: fig[f]["speed"])
            # The forearm arrives where the wrist first slows to a stop (a local minimum of its
            # speed, or slower than --hold-speed) after the sweep's peak ...
            w0 = next(f for f in range(peak + 1, end) if fig[f]["speed"] <= a.hold_speed or
                      (fig[f]["speed"] <= fig[f - 1]["speed"] and fig[f]["speed"] <= fig[f + 1]["speed"]))
            # ... and stays in place while the wrist is within --place of where it arrived.
            w1 = w0
            while w1 + 1 <= end and math.dist(all_pos[w1 + 1][w], all_pos[w0][w]) <= a.place * stature:
                w1 += 1
            x = fig[w0]
            win = [fig[f] for f in range(w0, w1 + 1)]
            print(f"{side}: peak {fig[peak]['speed']:.1f} m/s at f{peak}; intercept window [{w0}, {w1}]"
                  f" ({(w1 - w0 + 1) * dt:.2f} s){'  (past the segment end f%d)' % last if w1 > last else ''}")
            print("  at f{}: wrist {:.2f} elbow {:.2f} of stature, forearm {:+.0f} deg, wrist fwd {:+.2f} left {:+.2f}".format(
                w0, x["wrist"], x["elbow"], x["angle"], x["fwd"], x["left"]))
            print("  over the window: wrist {:.2f}..{:.2f}, elbow {:.2f}..{:.2f}, forearm {:+.0f}..{:+.0f} deg".format(
                min(v["wrist"] for v in win), max(v["wrist"] for v in win),
                min(v["elbow"] for v in win), max(v["elbow"] for v in win),
                min(v["angle"] for v in win), max(v["angle"] for v in win)))
        return
    if a.holds:
        for side in sides:
            fig = [figures(f, side) for f in range(len(frames))]
            min_hold = max(1, round(a.min_hold_s / dt))
            f = 0
            peak = 0.0
            while f < len(frames):
                peak = max(peak, fig[f]["speed"])
                if peak >= a.min_speed and fig[f]["speed"] <= a.hold_speed:
                    g = f
                    while g + 1 < len(frames) and fig[g + 1]["speed"] <= a.hold_speed:
                        g += 1
                    if g - f + 1 >= min_hold:
                        x = fig[f]
                        print(fmt.format(f, side, x["wrist"], x["elbow"], x["angle"], x["fwd"], x["left"], x["speed"])
                              + f"  held to f{g} (peak {peak:.1f} m/s before)")
                        peak = 0.0
                    f = g + 1
                    continue
                f += 1
        return
    first, last = a.frames if a.frames else (0, len(frames) - 1)
    for f in range(first, last + 1, a.step):
        for side in sides:
            x = figures(f, side)
            print(fmt.format(f, side, x["wrist"], x["elbow"], x["angle"], x["fwd"], x["left"], x["speed"]))


if __name__ == "__main__":
    sys.exit(main())
