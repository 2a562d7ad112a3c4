#!/usr/bin/env python3
"""scripts/judge-bvh.py on SYNTHETIC BVHs whose truth is known by construction.

A standing leg (metres, 60 Hz, 120 frames) whose body slides along x at 0.5 m/s with the foot
flat on the floor, once with every frame level and once with the whole body dipped 4 cm on one
frame (the toe under the floor, as a blow or a late landing can put it). The foot stands flat on
every frame in both, so the judge must count ~120 flat frames and a support slide of 0.5 m/s in
both; taking the file's plain lowest as the floor, the dipped file had 1 flat frame and no slide.
A third file folds the knee from straight to 175 degrees over the 120 frames (thigh and shin
0.45 m each): the ankle comes nearer the hip than 0.1 of the leg (0.09 m) past 168.5 degrees,
on the last 5 frames (the least share sin(2.5 deg) = 0.044 on the last); the level file folds none.
Usage: test-judge-bvh.py JUDGE (the path of scripts/judge-bvh.py)
"""
import importlib.util
import os
import sys
import tempfile

FPS = 60
FRAMES = 120
SLIDE_MPS = 0.5

HEADER = """HIERARCHY
ROOT hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT head
  {
    OFFSET 0 0.7 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 0.2 0
    }
  }
  JOINT lfemur
  {
    OFFSET 0.1 -0.05 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT ltibia
    {
      OFFSET 0 -0.45 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      JOINT lfoot
      {
        OFFSET 0 -0.45 0
        CHANNELS 3 Zrotation Xrotation Yrotation
        JOINT ltoes
        {
          OFFSET 0 -0.05 0.12
          CHANNELS 3 Zrotation Xrotation Yrotation
          End Site
          {
            OFFSET 0 0 0.05
          }
        }
      }
    }
  }
}
MOTION
"""


def write_bvh(path, dip_frame):
    lines = [HEADER, f"Frames: {FRAMES}\n", f"Frame Time: {1.0 / FPS:.6f}\n"]
    for f in range(FRAMES):
        x = SLIDE_MPS * f / FPS
        y = 0.95 - (0.04 if f == dip_frame else 0.0)  # the toe at y = 0 (or 4 cm under it)
        lines.append(" ".join([f"{x:.6f}", f"{y:.6f}", "0"] + ["0"] * 18) + "\n")
    with open(path, "w") as out:
        out.writelines(lines)


def write_folding_bvh(path):
    lines = [HEADER, f"Frames: {FRAMES}\n", f"Frame Time: {1.0 / FPS:.6f}\n"]
    for f in range(FRAMES):
        values = ["0", "0.95", "0"] + ["0"] * 18
        values[13] = f"{175.0 * f / (FRAMES - 1):.6f}"  # ltibia's Xrotation: the knee bends
        lines.append(" ".join(values) + "\n")
    with open(path, "w") as out:
        out.writelines(lines)


def main():
    spec = importlib.util.spec_from_file_location("judge_bvh", sys.argv[1])
    judge = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(judge)
    bad = []
    with tempfile.TemporaryDirectory() as d:
        for name, dip in (("level", None), ("dipped", 60)):
            path = os.path.join(d, name + ".bvh")
            write_bvh(path, dip)
            r = judge.judge(path, 0, None)
            flat, slide = r["left_flat_frames"], r["left_support_slide_mps"]
            print(f"{name}: left_flat_frames {flat}, left_support_slide_mps {slide}")
            if flat < FRAMES - 2:
                bad.append(f"{name}: {flat} flat frames, the foot stands flat on all {FRAMES}")
            if abs(slide - SLIDE_MPS) > 0.05:
                bad.append(f"{name}: support slide {slide} m/s, the foot slides at {SLIDE_MPS}")
            if r["folded_frames"] != 0:
                bad.append(f"{name}: {r['folded_frames']} folded frames, the leg stands straight")
        path = os.path.join(d, "folding.bvh")
        write_folding_bvh(path)
        r = judge.judge(path, 0, None)
        leg = r["folded"]["left_leg"]
        print(f"folding: folded_frames {r['folded_frames']}, left leg least share {leg['min_share']} at frame {leg['frame']}")
        if r["folded_frames"] != 5 or leg["frame"] != FRAMES - 1 or abs(leg["min_share"] - 0.044) > 0.002:
            bad.append(f"folding: {r['folded_frames']} folded frames, least share {leg['min_share']} at {leg['frame']}"
                       f" (5, 0.044 at {FRAMES - 1} by construction)")
    for b in bad:
        print("FAIL:", b)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
