#!/usr/bin/python3
"""Plot `kumite-recognise eval`'s report: DTW and the learned recogniser side by side.

  recognition/train/plot_eval.py report.json report.png
"""
import json
import os
import sys
import tempfile

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

SYSTEMS = [("dtw", "dual-buffer DTW", "tab:blue"), ("learned", "learned (Touché CNN)", "tab:orange")]


def per_strike(r):
    out = []
    for f in r["leave_one_actor_out"]:
        out += f.get("per_strike", [])
    out += r["external_actors"].get("per_strike", [])
    return out


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    with open(sys.argv[1]) as f:
        rep = json.load(f)
    systems = [s for s in SYSTEMS if s[0] in rep]
    fig, ax = plt.subplots(2, 3, figsize=(16, 9.5))
    # 1. Headline accuracies against the targets.
    a = ax[0, 0]
    labels = ["right limb %", "right kind %"]
    w = 0.38
    for i, (k, name, c) in enumerate(systems):
        h = rep[k]["held_out_total"]
        vals = [h["right_limb_pct"], h["right_kind_pct"]]
        bars = a.bar(np.arange(2) + (i - 0.5) * w, vals, w, label=name, color=c)
        a.bar_label(bars, fmt="%.1f")
    a.plot([-0.4, 0.4], [95, 95], "k--", lw=1)
    a.plot([0.6, 1.4], [85, 85], "k--", lw=1, label="target")
    a.set_xticks(range(2), labels)
    a.set_ylim(0, 105)
    a.set_title(f"held-out strikes (n = {rep[systems[0][0]]['held_out_total']['strikes']})")
    a.legend(loc="lower right")
    # 2. Accuracy against progress (onset -> hit).
    a = ax[0, 1]
    for k, name, c in systems:
        acc = rep[k]["held_out_total"]["correct_pct_at_progress"]
        xs = sorted(acc, key=float)
        a.plot([float(x) * 100 for x in xs], [acc[x] for x in xs], "o-", color=c, label=name)
    a.set_xlabel("% of the way from onset to full extension")
    a.set_ylabel("% strikes with the right limb + action active")
    a.set_ylim(0, 100)
    a.set_title("accuracy against progress")
    a.grid(alpha=0.3)
    a.legend()
    # 3. Decision latency from onset (per strike).
    a = ax[0, 2]
    data = []
    for k, name, c in systems:
        data.append([s["latency_ms"] for s in per_strike(rep[k]) if s["latency_ms"] is not None])
    parts = a.boxplot(data, labels=[s[1] for s in systems], showmeans=False)
    for i, d in enumerate(data):
        a.scatter(np.full(len(d), i + 1) + np.random.default_rng(0).uniform(-0.08, 0.08, len(d)), d, s=10,
                  color=systems[i][2], alpha=0.6)
    a.axhline(100, color="k", ls="--", lw=1, label="target p50 100 ms")
    a.set_ylabel("first event after onset (ms)")
    a.set_title("decision latency (detected strikes): p50 " +
                ", ".join(f"{rep[k]['held_out_total']['latency_from_onset_ms']['p50']:.0f}" for k, _, _ in systems) + " ms")
    a.legend()
    # 4, 5. Confusion matrices.
    for i, (k, name, c) in enumerate(systems[:2]):
        a = ax[1, i]
        conf = rep[k]["held_out_total"]["confusion"]
        truth = sorted(conf)
        pred = sorted({p for t in conf for p in conf[t]} | set(truth))
        m = np.array([[conf[t].get(p, 0) for p in pred] for t in truth])
        a.imshow(m, cmap="Blues")
        for (r, q), v in np.ndenumerate(m):
            a.text(q, r, str(v), ha="center", va="center", color="white" if v > m.max() / 2 else "black")
        a.set_xticks(range(len(pred)), pred, rotation=30, ha="right")
        a.set_yticks(range(len(truth)), truth)
        a.set_xlabel("predicted")
        a.set_ylabel("truth")
        a.set_title(f"confusion: {name}")
    # 6. False triggers and compute.
    a = ax[1, 2]
    names = [s[1] for s in systems]
    ft = [rep[k]["false_triggers"]["per_idle_minute"] for k, _, _ in systems]
    cpu = [rep[k]["loop_cpu_us"]["p99"] for k, _, _ in systems]
    bars = a.bar(np.arange(len(systems)) - 0.2, ft, 0.38, color=[s[2] for s in systems])
    a.bar_label(bars, fmt="%.1f /min")
    a.axhline(2, color="k", ls="--", lw=1)
    a.set_ylabel("false triggers per idle minute (target <= 2)")
    a2 = a.twinx()
    bars = a2.bar(np.arange(len(systems)) + 0.2, cpu, 0.38, color=[s[2] for s in systems], alpha=0.4, hatch="//")
    a2.bar_label(bars, fmt="%.0f µs")
    a2.set_ylabel("compute per loop, p99 (µs; hatched)")
    a.set_xticks(range(len(systems)), names)
    a.set_title(f"false triggers ({rep[systems[0][0]]['false_triggers']['minutes']:.2f} idle min) and compute")
    fig.suptitle("kumite-recognise eval: held-out actors only (leave one actor out + external boxer / Sony)")
    fig.tight_layout()
    out = sys.argv[2]
    fd, tmp = tempfile.mkstemp(dir=os.path.dirname(os.path.abspath(out)), suffix=".png")
    os.close(fd)
    fig.savefig(tmp, dpi=90)
    os.chmod(tmp, 0o644)
    os.replace(tmp, out)
    print(json.dumps({"out": out}))


if __name__ == "__main__":
    main()
