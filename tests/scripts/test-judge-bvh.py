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
Two more bend the knee 90 degrees (the thigh 45 degrees forward, the ankle under the hip: the knee
0.32 m, 0.35 of the leg, off the hip-ankle line) and turn the whole body about the vertical 3
degrees a frame (180 deg/s), one of them 60 degrees more on frame 60 alone: the knee turns about
its leg's line at (3 + 60) x 60 = 3780 deg/s there, one limb-swing frame over 2000 deg/s; the
other has none (180 deg/s). A last file has no joint the judge knows as a foot: it says so
("feet": "none found by name"), where it used to stop on an IndexError (the Sony clips' names).
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


def write_spinning_bvh(path, jump_deg):
    lines = [HEADER, f"Frames: {FRAMES}\n", f"Frame Time: {1.0 / FPS:.6f}\n"]
    for f in range(FRAMES):
        values = ["0", "0.95", "0"] + ["0"] * 18
        values[5] = f"{3.0 * f + (jump_deg if f >= 60 else 0.0):.6f}"  # hips' Yrotation: the body turns
        values[10] = "-45"  # lfemur's Xrotation: the thigh forward
        values[13] = "90"   # ltibia's Xrotation: the knee bent, the ankle under the hip
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
        for name, jump in (("turning", 0.0), ("swung", 60.0)):
            path = os.path.join(d, name + ".bvh")
            write_spinning_bvh(path, jump)
            r = judge.judge(path, 0, None)
            leg = r["swing"]["left_leg"]
            print(f"{name}: swing_frames {r['swing_frames']}, left leg fastest {leg['max_deg_s']} deg/s at frame {leg['frame']}")
            want = (1, 3780, 60) if jump else (0, 180, None)
            if r["swing_frames"] != want[0] or abs(leg["max_deg_s"] - want[1]) > 5 or (want[2] is not None and leg["frame"] != want[2]):
                bad.append(f"{name}: {r['swing_frames']} swing frames, fastest {leg['max_deg_s']} deg/s at {leg['frame']}"
                           f" ({want[0]}, {want[1]} deg/s by construction)")
        path = os.path.join(d, "footless.bvh")
        with open(path, "w") as out:
            out.write("HIERARCHY\nROOT pelvis\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
                      "  JOINT spine\n  {\n    OFFSET 0 0.5 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n"
                      "    End Site\n    {\n      OFFSET 0 0.2 0\n    }\n  }\n}\nMOTION\n"
                      f"Frames: 3\nFrame Time: {1.0 / FPS:.6f}\n" + "0 1 0 0 0 0 0 0 0\n" * 3)
        r = judge.judge(path, 0, None)
        print(f"footless: feet {r.get('feet')!r}, folded_frames {r['folded_frames']}")
        if r.get("feet") != "none found by name":
            bad.append(f"footless: feet {r.get('feet')!r}, not 'none found by name'")
    for b in bad:
        print("FAIL:", b)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
