#!/usr/bin/env python3
"""The strike grid judged as a viewer would, independent of Kumite's C++ figures.

Runs `kumite-motion strike` for 5 characters x 4 orders x 12 targets (punches at head height,
kicks 0.45 m lower, 0.45-0.65 x stature in front, 0.15 m either side), reads every written
BVH with scripts/judge-bvh.py's own parser and forward kinematics, and judges the same
figures on the source clip over the frames that played.

  scripts/judge-strikes.py [--bin build/bin] [--db build/demo/fighter.kdb] [--out DIR] [--quick]
                           [--tunables FILE]   (kumite-motion --tunables: the fighter's tunables)
Prints one JSON summary (and writes DIR/grid.json with every strike).
"""
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import importlib.util

spec = importlib.util.spec_from_file_location("judge_bvh", os.path.join(os.path.dirname(os.path.abspath(__file__)), "judge-bvh.py"))
judge_bvh = importlib.util.module_from_spec(spec)
spec.loader.exec_module(judge_bvh)

STATURE = {"kenji": 1.70, "mei": 1.52, "bruno": 1.92, "aiko": 1.62, "viktor": 1.84}
ORDERS = ["punch_left", "punch_right", "kick_left", "kick_right"]


def targets(stature, kick, quick):
    head = 0.93 * stature
    y = head - 0.45 if kick else head
    zs = [0.45, 0.52, 0.58, 0.65] if not quick else [0.5]
    xs = [-0.15, 0.0, 0.15] if not quick else [0.0]
    return [(x, y, z * stature) for z in zs for x in xs]


def main():
    args = sys.argv[1:]
    opt = {"--bin": "build/bin", "--db": "build/demo/fighter.kdb", "--out": "out/strike-grid", "--tunables": ""}
    quick = "--quick" in args
    for k in list(opt):
        if k in args:
            opt[k] = args[args.index(k) + 1]
    os.makedirs(opt["--out"], exist_ok=True)
    rows = []
    src_cache = {}
    for name, stature in STATURE.items():
        for order in ORDERS:
            for i, t in enumerate(targets(stature, order.startswith("kick"), quick)):
                stem = os.path.join(opt["--out"], f"{name}-{order}-{i:02d}")
                tun = ["--tunables", opt["--tunables"]] if opt["--tunables"] else []
                r = subprocess.run([os.path.join(opt["--bin"], "kumite-motion"), *tun, "strike", "--db", opt["--db"],
                                    "--character", name, "--order", order, "--target", "{:.4f},{:.4f},{:.4f}".format(*t), "--out", stem + ".bvh",
                                    "--report", stem + ".json"], capture_output=True, text=True)
                if r.returncode != 0:
                    rows.append({"strike": stem, "error": r.stderr.strip()})
                    continue
                rep = json.load(open(stem + ".json"))
                out = judge_bvh.judge(stem + ".bvh")
                clip = os.path.join("content", "motions", rep["clip"] + ".bvh")
                key = (clip, rep["start_frame"], rep["frames"], name)
                if key not in src_cache:
                    # bones: the source also laid on the character's bones (same joints only)
                    src_cache[key] = judge_bvh.judge(clip, rep["start_frame"], rep["start_frame"] + rep["frames"], bones=stem + ".bvh")
                src = src_cache[key]
                rows.append({"strike": stem, "segment": rep["segment"], "reach_error_m": rep["reach_error_m"],
                             "reachable": rep["reachable"], "out": out, "src": src})
    ok = [r for r in rows if "out" in r]
    def slide(j):
        return max(j.get("left_support_slide_mps", 0), j.get("right_support_slide_mps", 0))
    def peak(j):
        return max(j.get("left_peak_foot_speed_mps", 0), j.get("right_peak_foot_speed_mps", 0))
    def size_scaled(rows):
        v = [(r["out"]["p99_joint_speed_mps"] / max(1e-9, r["src"]["p99_joint_speed_mps"] * r["out"]["leg_m"] / r["src"]["leg_m"]), r["strike"])
             for r in rows if r["out"].get("leg_m") and r["src"].get("leg_m")]
        if not v:
            return None
        x = sorted(a for a, _ in v)
        return {"strikes": len(v), "p50": round(judge_bvh.pct(x, 50), 3), "p95": round(judge_bvh.pct(x, 95), 3), "max": round(x[-1], 3),
                "over_1_2": sum(1 for a in x if a > 1.2), "worst": [(round(a, 3), os.path.basename(s)) for a, s in sorted(v, reverse=True)[:3]]}
    def on_bones(rows):
        v = [(r["out"]["p99_joint_speed_mps"] / max(1e-9, r["src"]["p99_joint_speed_on_bones_mps"]), r["strike"])
             for r in rows if r["src"].get("p99_joint_speed_on_bones_mps")]
        if not v:
            return None
        x = sorted(a for a, _ in v)
        return {"strikes": len(v), "p50": round(judge_bvh.pct(x, 50), 3), "p95": round(judge_bvh.pct(x, 95), 3), "max": round(x[-1], 3),
                "over_1_2": sum(1 for a in x if a > 1.2), "worst": [(round(a, 3), os.path.basename(s)) for a, s in sorted(v, reverse=True)[:3]]}
    slides = [slide(r["out"]) for r in ok]
    src_slides = [slide(r["src"]) for r in ok]
    summary = {
        "strikes": len(rows), "errors": len(rows) - len(ok),
        "with_snaps": sum(1 for r in ok if r["out"]["snaps"] > 0),
        "source_with_snaps": sum(1 for r in ok if r["src"]["snaps"] > 0),
        "p99_speed_ratio_max": round(max(r["out"]["p99_joint_speed_mps"] / max(1e-9, r["src"]["p99_joint_speed_mps"]) for r in ok), 2),
        # The same with the source's speeds scaled to the character's size (leg over leg, each
        # from its file's own offsets): m/s compared across bodies of different sizes.
        "p99_speed_ratio_size_scaled": size_scaled(ok),
        # And with the source laid on the character's own bones (each source bone along its own
        # direction at the character's bone length, the root's way scaled leg over leg): a
        # character whose arms are long for its legs moves its fists faster on the same angles.
        "p99_speed_ratio_on_character_bones": on_bones(ok),
        "support_slide_mps": {"p50": round(judge_bvh.pct(slides, 50), 3), "p95": round(judge_bvh.pct(slides, 95), 3), "max": round(max(slides), 3)},
        "source_support_slide_mps": {"p50": round(judge_bvh.pct(src_slides, 50), 3), "p95": round(judge_bvh.pct(src_slides, 95), 3), "max": round(max(src_slides), 3)},
        "slide_over_source_by_0_3": sum(1 for r in ok if slide(r["out"]) > slide(r["src"]) + 0.3),
        "foot_peak_ratio_max": round(max(peak(r["out"]) / max(1e-9, peak(r["src"])) for r in ok), 2),
        "reach_error_mm": {"p50": round(judge_bvh.pct([r["reach_error_m"] * 1000 for r in ok], 50), 2),
                           "max_reachable": round(max([r["reach_error_m"] * 1000 for r in ok if r["reachable"]] or [0]), 2)},
        "reachable": sum(1 for r in ok if r["reachable"]),
        "worst_snaps": sorted(((r["out"]["snaps"], r["strike"], r["out"]["snap_list"][:3]) for r in ok), reverse=True)[:5],
    }
    json.dump({"summary": summary, "rows": rows}, open(os.path.join(opt["--out"], "grid.json"), "w"), indent=1)
    print(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
