#!/usr/bin/env python3
"""The scripted bout in every order of the five shipped characters (120 bouts), summed.

One scripted bout (`kumite-motion bout`) holds about ten strikes; six orders, the figure the
notes quoted up to session 28, hold about 60, and a change to the behaviour moves every later
strike of a bout (the visitor, the spot and the feet all differ from the first changed frame
on), so a change of 2-4 folded strikes in six bouts is within the noise. All 120 orders give
about 1,250 strikes. Each bout's report (its `summary`, `events`, contacts) is the tool's own,
judged on the drawn joints; this script only runs the bouts and adds them up.

  scripts/bout-sweep.py --tool build/bin/kumite-motion --db build/demo/fighter.kdb --out DIR \\
      [--tunables FILE] [--jobs 2] [--characters aiko,bruno,kenji,mei,viktor]

Writes DIR/oN/bout.json (+ run BVH) for each order, DIR/orders.txt and DIR/sweep.json, and prints
the totals as one JSON object. Exit 1 with one line naming the bout when a bout fails.
"""
import argparse
import concurrent.futures
import itertools
import json
import os
import subprocess
import sys

SUMMED = ["strikes", "hits", "dodged", "misses", "folded_at_contact", "elbow_flips", "knee_flips",
          "both_feet_off_frames", "both_feet_off_frames_source_down", "drawn_snaps_whole_bout",
          "snaps_in_bvh_runs"]


def run_one(args, i, order):
    out = os.path.join(args.out, f"o{i}")
    os.makedirs(out, exist_ok=True)
    cmd = [args.tool]
    if args.tunables:
        cmd += ["--tunables", args.tunables]
    cmd += ["bout", "--db", args.db, "--out", os.path.join(out, "bout.bvh"), "--report",
            os.path.join(out, "bout.json"), "--characters", order]
    r = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        last = (r.stderr.strip().splitlines() or ["(no message)"])[-1]
        raise RuntimeError(f"bout {i} ({order}) exited {r.returncode}: {last}")
    with open(os.path.join(out, "bout.json")) as f:
        return json.load(f)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--tool", required=True, help="kumite-motion")
    p.add_argument("--db", required=True, help="fighter.kdb")
    p.add_argument("--out", required=True, help="directory for the bouts' reports and BVH")
    p.add_argument("--tunables", help="tunables TOML passed to every bout")
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--characters", default="aiko,bruno,kenji,mei,viktor", help="the characters to permute")
    args = p.parse_args()
    for path, what in ((args.tool, "--tool"), (args.db, "--db")) + (((args.tunables, "--tunables"),) if args.tunables else ()):
        if not os.path.isfile(path):
            print(f"bout-sweep: {what}: no such file: {path}", file=sys.stderr)
            return 1
    if args.jobs < 1:
        print("bout-sweep: --jobs: must be at least 1", file=sys.stderr)
        return 1
    names = [c for c in args.characters.split(",") if c]
    orders = [",".join(o) for o in itertools.permutations(names)]
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "orders.txt"), "w") as f:
        f.write("\n".join(orders) + "\n")
    totals = {k: 0 for k in SUMMED}
    totals.update(orders_ignored=0, bouts=0)
    folded = []
    try:
        with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
            reports = list(pool.map(lambda io: run_one(args, *io), enumerate(orders)))
    except RuntimeError as e:
        print(f"bout-sweep: {e}", file=sys.stderr)
        return 1
    for i, r in enumerate(reports):
        s = r["summary"]
        for k in SUMMED:
            totals[k] += s[k]
        totals["orders_ignored"] += sum(1 for e in r["events"] if "order_ignored" in e)
        for field, prefix in (("both_feet_off_frames_by_state", "both_feet_off_"),
                              ("both_feet_off_frames_source_down_by_state", "both_feet_off_source_down_")):
            for state, n in s.get(field, {}).items():
                totals[prefix + state] = totals.get(prefix + state, 0) + n
        totals["bouts"] += 1
        ft = r["frame_time_s"]
        for run in r["runs"]:
            for c in run["contacts"]:
                if c["folded"]:
                    folded.append({"bout": i, "order": orders[i], "character": run["character"],
                                   "t_s": round((run["first_frame"] + c["frame"]) * ft, 3), "limb": c["limb"],
                                   "outcome": c["outcome"], "elbow_above_head": bool(c.get("elbow_above_head"))})
    result = {"totals": totals, "folded": folded, "tunables": args.tunables, "orders": len(orders)}
    tmp = os.path.join(args.out, "sweep.json.tmp")
    with open(tmp, "w") as f:
        json.dump(result, f, indent=1)
        f.write("\n")
    os.replace(tmp, os.path.join(args.out, "sweep.json"))
    print(json.dumps(totals))
    return 0


if __name__ == "__main__":
    sys.exit(main())
