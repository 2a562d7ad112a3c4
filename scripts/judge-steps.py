#!/usr/bin/env python3
"""Judge the fighter's stance steps as a viewer would, beside the mocap each was cut from.

Reads the JSON of `kumite-motion bout` (its stance_step_list: each stance step the fighter
took, which walk segment, where in which run BVH) and, with judge-bvh.py's own BVH parser and
forward kinematics (independent of Kumite's C++), compares over each step:
  - the stepping foot's peak speed (ankle, over ~33 ms) drawn / in the source clip's frames,
    the source scaled to the character's size (leg over leg)
  - p99 joint speed, drawn / source (size-scaled)
  - support-foot slide (horizontal speed while ankle and toe stand flat), drawn and source
  - snaps (judge-bvh.py's rule) in the drawn frames

  scripts/judge-steps.py bout.json [--motions content/motions] [--json]
The run BVH paths are the ones the bout JSON names (relative to the current directory).
"""
import importlib.util
import json
import os
import statistics
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
spec = importlib.util.spec_from_file_location("judge_bvh", os.path.join(HERE, "judge-bvh.py"))
jb = importlib.util.module_from_spec(spec)
spec.loader.exec_module(jb)


def main():
    args = sys.argv[1:]
    as_json = "--json" in args
    args = [a for a in args if a != "--json"]
    motions = os.path.join(HERE, "..", "content", "motions")
    if "--motions" in args:
        k = args.index("--motions")
        motions = args[k + 1]
        del args[k:k + 2]
    if len(args) != 1:
        print(__doc__.strip().splitlines()[-2].strip(), file=sys.stderr)
        return 2
    with open(args[0]) as f:
        bout = json.load(f)
    runs = bout["runs"]
    dt = bout["frame_time_s"]
    rows = []
    for st in bout.get("stance_step_list", []):
        run = runs[st["run"] - 1]
        tail = round(0.25 / dt)  # the blend into the rest motion after it
        a = st["run_frame"]
        b = min(run["frames"], a + st["frames_played"] + tail)
        drawn = jb.judge(run["bvh"], a, b)
        src_file = os.path.join(motions, st["source_clip"] + ".bvh")
        s0 = st["source_first_frame"]
        source = jb.judge(src_file, s0, s0 + st["source_frames"])
        size = drawn["leg_m"] / source["leg_m"]
        peak = lambda r: max(r.get("left_peak_foot_speed_mps", 0), r.get("right_peak_foot_speed_mps", 0))
        slide = lambda r: max(r.get("left_support_slide_mps", 0), r.get("right_support_slide_mps", 0))
        rows.append({
            "segment": st["segment"], "run": st["run"], "frames": [a, b], "travel_scale": st["travel_scale"],
            "whole": st["frames_played"] * dt >= st["source_frames"] * st["source_frame_time_s"] - 0.3,
            "size": round(size, 3),
            "foot_peak_mps": peak(drawn), "source_foot_peak_mps": round(peak(source) * size, 2),
            "foot_peak_ratio": round(peak(drawn) / max(1e-9, peak(source) * size), 3),
            "p99_ratio": round(drawn["p99_joint_speed_mps"] / max(1e-9, source["p99_joint_speed_mps"] * size), 3),
            "support_slide_mps": slide(drawn), "source_support_slide_mps": slide(source),
            "snaps": drawn["snaps"],
        })
    def dist(v):
        return {"p50": round(statistics.median(v), 3), "max": round(max(v), 3)} if v else {}
    whole = [r for r in rows if r["whole"]]
    summary = {
        "steps": len(rows), "whole_steps": len(whole), "snaps": sum(r["snaps"] for r in rows),
        "foot_peak_ratio": dist([r["foot_peak_ratio"] for r in whole]),
        "p99_ratio": dist([r["p99_ratio"] for r in whole]),
        "support_slide_mps": dist([r["support_slide_mps"] for r in rows]),
        "source_support_slide_mps": dist([r["source_support_slide_mps"] for r in rows]),
    }
    if as_json:
        print(json.dumps({"summary": summary, "steps": rows}, indent=1))
    else:
        for r in rows:
            print(f"{r['segment']:24s} run {r['run']} frames {r['frames'][0]}-{r['frames'][1]} scale {r['travel_scale']:.2f}"
                  f"{'' if r['whole'] else ' (cut short)'}: foot peak {r['foot_peak_mps']} vs source {r['source_foot_peak_mps']} m/s"
                  f" ({r['foot_peak_ratio']}x), p99 {r['p99_ratio']}x, support slide {r['support_slide_mps']}"
                  f" vs {r['source_support_slide_mps']} m/s, snaps {r['snaps']}")
        print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
