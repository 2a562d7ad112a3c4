#!/usr/bin/env python3
"""A film strip of a BVH as PNG, to look at: stick figures side by side, independent of Kumite's C++.

Pure Python (judge-bvh.py's own parser and forward kinematics, zlib for the PNG): PANELS poses
evenly spread from frame FIRST to LAST, drawn from the side (room Z across, Y up; --axis x
for X across), left limbs red, right limbs blue, the floor grey with a tick every 0.25 m. All
panels share one scale and one horizontal origin, so travel across the strip is the body's.

  scripts/film-bvh.py IN.bvh FIRST LAST PANELS OUT.png [--axis z|x]
"""
import importlib.util
import math
import os
import struct
import sys
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
spec = importlib.util.spec_from_file_location("judge_bvh", os.path.join(HERE, "judge-bvh.py"))
jb = importlib.util.module_from_spec(spec)
spec.loader.exec_module(jb)

W, H, S = 330, 420, 200  # panel width and height (px), px per metre


def main():
    args = sys.argv[1:]
    axis = "z"
    if "--axis" in args:
        k = args.index("--axis")
        axis = args[k + 1]
        del args[k:k + 2]
    if len(args) != 5 or axis not in ("x", "z"):
        print(__doc__.strip().splitlines()[-1].strip(), file=sys.stderr)
        return 2
    path, out = args[0], args[4]
    try:
        first, last, n = int(args[1]), int(args[2]), int(args[3])
    except ValueError:
        print(f"film-bvh: FIRST, LAST and PANELS must be whole numbers, got {args[1:4]}", file=sys.stderr)
        return 2
    names, parents, offsets, channels, dt, frames = jb.parse_bvh(path)
    if not (0 <= first <= last < len(frames)) or not (1 <= n <= 40):
        print(f"film-bvh: {path}: frames {first}..{last} outside 0..{len(frames) - 1}, or panels {n} outside 1..40",
              file=sys.stderr)
        return 2
    unit = jb.guess_unit(jb.fk(names, parents, offsets, channels, frames[first]), names)
    idx = [round(first + (last - first) * i / max(1, n - 1)) for i in range(n)]
    poses = [[tuple(c * unit for c in p) for p in jb.fk(names, parents, offsets, channels, frames[f])] for f in idx]
    ax = 2 if axis == "z" else 0
    across = [p[ax] for pose in poses for p in pose]
    mid = (min(across) + max(across)) / 2
    img = [bytearray(b"\xff" * (W * n * 3)) for _ in range(H)]

    def put(x, y, c):
        if 0 <= x < W * n and 0 <= y < H:
            img[y][3 * x:3 * x + 3] = bytes(c)

    def line(x0, y0, x1, y1, c):
        steps = int(max(abs(x1 - x0), abs(y1 - y0))) + 1
        for i in range(steps + 1):
            t = i / steps
            put(int(round(x0 + (x1 - x0) * t)), int(round(y0 + (y1 - y0) * t)), c)

    floor = H - 20
    for k, pose in enumerate(poses):
        ox = k * W
        X = lambda v: ox + W / 2 + (v - mid) * S
        Y = lambda y: floor - y * S
        line(ox, floor, ox + W - 1, floor, (150, 150, 150))
        for m in range(-6, 7):
            v = round(mid * 4) / 4 + m * 0.25
            line(int(X(v)), floor, int(X(v)), floor + 6, (150, 150, 150))
        for j, p in enumerate(parents):
            if p < 0:
                continue
            nm = names[j].lower()
            side = nm.startswith("l") or "left" in nm
            right = nm.startswith("r") or "right" in nm
            colour = (200, 40, 40) if side else (40, 40, 200) if right else (0, 0, 0)
            line(X(pose[p][ax]), Y(pose[p][1]), X(pose[j][ax]), Y(pose[j][1]), colour)
        line(ox + W - 1, 0, ox + W - 1, H - 1, (220, 220, 220))
    raw = b"".join(b"\x00" + bytes(r) for r in img)

    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xFFFFFFFF)

    tmp = out + ".tmp"
    with open(tmp, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", W * n, H, 8, 2, 0, 0, 0)) +
                chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
    os.replace(tmp, out)
    print(f"wrote {out}: frames {idx}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
