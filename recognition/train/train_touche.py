#!/usr/bin/python3
"""Train the learned strike recogniser (Touche, CHI 2020) offline; export it for the C++ library.

Per 60 Hz loop and limb the network reads the last 16 loops of the limb's input (head-relative
position and velocity, exponentially smoothed, in head heights, left limbs mirrored: what
`kumite-recognise dataset` writes) and outputs the strike class (the actions the data has for
that limb kind, plus "none") and the strike's progress 0..1 (0 at the onset, 1 at full
extension). Network: two 1-D dilated causal convolutions (100 channels; kernel 4, dilations 1
and 4: a 16-loop receptive field), ReLU, then a 1x1 convolution to the class logits and the
progress (sigmoid). One network per limb kind (hand, foot).

Training data are augmented x6 (AUGMENTATION, labelled as such, never evaluated on): every
training sequence gets 6 perturbed copies (height offset, scale, speed, a smooth trajectory
offset, a yaw turn). Deterministic: fixed seeds, one thread, deterministic algorithms.

  kumite-recognise dataset --out build/touche/dataset.json
  recognition/train/train_touche.py --dataset build/touche/dataset.json --out recognition/models/strikes.klearn
  recognition/train/train_touche.py --dataset build/touche/dataset.json --eval-dir build/touche
      (the cross-actor folds kumite-recognise eval --learned build/touche reads)
  recognition/train/train_touche.py --fixture tests/recognition/data
      (a small SYNTHETIC-weights model and the torch outputs the C++ inference must match)

Model file (.klearn): text; line 1 "kumite-learned-model 1", line 2 "checksum fnv1a64 <hex>" of
every byte after line 2, then "note", "setting" lines, per net a "net" line and its tensors as
"tensor <name> <dims...> <base64 of little-endian float32>", and "end".
"""
import argparse
import base64
import json
import math
import os
import sys
import tempfile

import numpy as np
import torch
from torch import nn

MAGIC = "kumite-learned-model"
VERSION = 1
WINDOW = 16
K1, D1, K2, D2 = 4, 1, 4, 4
assert 1 + (K1 - 1) * D1 + (K2 - 1) * D2 == WINDOW
HIDDEN = 100
INPUT = 6
AUGMENT = 6
LIMBS = ["left_hand", "right_hand", "left_foot", "right_foot"]
KIND_OF_LIMB = ["hand", "hand", "foot", "foot"]


def fnv1a64(data: bytes) -> int:
    h = 1469598103934665603
    for b in data:
        h ^= b
        h = (h * 1099511628211) & 0xFFFFFFFFFFFFFFFF
    return h


class Net(nn.Module):
    def __init__(self, classes: int, hidden: int = HIDDEN):
        super().__init__()
        self.conv1 = nn.Conv1d(INPUT, hidden, K1, dilation=D1)
        self.conv2 = nn.Conv1d(hidden, hidden, K2, dilation=D2)
        self.out = nn.Conv1d(hidden, classes + 1, 1)
        self.register_buffer("mean", torch.zeros(INPUT))
        self.register_buffer("std", torch.ones(INPUT))

    def forward(self, x):
        """x: [B, T, 6] raw inputs, T >= 16 -> logits [B, T-15, C], progress [B, T-15]."""
        x = (x - self.mean) / self.std
        h = torch.relu(self.conv1(x.transpose(1, 2)))
        h = torch.relu(self.conv2(h))
        o = self.out(h).transpose(1, 2)
        return o[..., :-1], torch.sigmoid(o[..., -1])


# ---- data ------------------------------------------------------------------------------------


def sequences(dataset, recordings, kind):
    """(x [N,6], class [N], progress [N]) per valid run of each limb of `kind`."""
    out = []
    for r in recordings:
        n = len(r["x"])
        for li, limb in enumerate(LIMBS):
            if KIND_OF_LIMB[li] != kind:
                continue
            start = None
            for i in range(n + 1):
                valid = i < n and r["x"][i][li] is not None
                if valid and start is None:
                    start = i
                if not valid and start is not None:
                    if i - start >= 2:
                        x = np.array([r["x"][j][li] for j in range(start, i)], dtype=np.float64)
                        y = np.array([r["class"][j][li] for j in range(start, i)], dtype=np.int64)
                        p = np.array([r["progress"][j][li] for j in range(start, i)], dtype=np.float64)
                        out.append((x, y, p))
                    start = None
    return out


def augment(seq, rng, velocity_weight, loop_hz):
    """One perturbed copy (AUGMENTATION): speed, scale, height, trajectory, orientation."""
    x, y, p = seq
    n = len(x)
    # Speed: resample in time (f > 1 faster); velocity scales with it.
    f = rng.uniform(0.8, 1.25)
    m = max(2, int(round((n - 1) / f)) + 1)
    t = np.minimum(np.arange(m) * f, n - 1)
    i0 = np.floor(t).astype(int)
    i1 = np.minimum(i0 + 1, n - 1)
    w = (t - i0)[:, None]
    xs = (1 - w) * x[i0] + w * x[i1]
    xs[:, 3:] *= f
    near = np.where(w[:, 0] < 0.5, i0, i1)
    ys = y[near].copy()
    same = (y[i0] == y[i1]) & (y[i0] > 0)
    ps = np.where(same, (1 - w[:, 0]) * p[i0] + w[:, 0] * p[i1], p[near])
    # Scale (stature relative to the head height) and a height offset of the limb.
    s = rng.uniform(0.9, 1.1)
    xs *= s
    xs[:, 1] += rng.uniform(-0.04, 0.04)
    # Trajectory: a smooth offset (two sinusoids per axis, periods 0.4..2 s, <= 0.03 head heights).
    tt = np.arange(m) / loop_hz
    for a in range(3):
        for _ in range(2):
            amp, per, ph = rng.uniform(0, 0.015), rng.uniform(0.4, 2.0), rng.uniform(0, 2 * math.pi)
            om = 2 * math.pi / per
            xs[:, a] += amp * np.sin(om * tt + ph)
            xs[:, 3 + a] += amp * om * np.cos(om * tt + ph) * velocity_weight
    # Orientation: a yaw turn of +-15 degrees (x right, z back).
    th = math.radians(rng.uniform(-15, 15))
    c, sn = math.cos(th), math.sin(th)
    for o in (0, 3):
        xx, zz = xs[:, o].copy(), xs[:, o + 2].copy()
        xs[:, o] = c * xx + sn * zz
        xs[:, o + 2] = -sn * xx + c * zz
    return xs, ys, ps


def chunks(seqs, length=64):
    """Left-pad each sequence with its first frame (WINDOW-1 loops: the C++ history does the
    same), cut into chunks of `length` outputs (+ WINDOW-1 context)."""
    xs, ys, ps = [], [], []
    for x, y, p in seqs:
        xp = np.concatenate([np.repeat(x[:1], WINDOW - 1, axis=0), x])
        for s in range(0, len(x), length):
            e = min(len(x), s + length)
            cx = xp[s:e + WINDOW - 1]
            cy, cp = y[s:e], p[s:e]
            pad = length - (e - s)
            if pad:
                cx = np.concatenate([cx, np.repeat(cx[-1:], pad, axis=0)])
                cy = np.concatenate([cy, np.full(pad, -1)])
                cp = np.concatenate([cp, np.full(pad, -1.0)])
            xs.append(cx)
            ys.append(cy)
            ps.append(cp)
    return (torch.tensor(np.array(xs), dtype=torch.float32), torch.tensor(np.array(ys), dtype=torch.long),
            torch.tensor(np.array(ps), dtype=torch.float32))


CLASS_WEIGHT = "none"
BEGIN_PROBABILITY = 0.8
NONE_THINNING = 3


def train_net(seqs, naug, classes, seed, epochs, log):
    """seqs: the real sequences then the augmented ones (the last `naug`). Chunks of augmented
    copies with no strike loop are thinned to one in three (they add little: the machine is small)."""
    torch.manual_seed(seed)
    x, y, p = chunks(seqs[:len(seqs) - naug])
    xa, ya, pa = chunks(seqs[len(seqs) - naug:])
    keep = (ya > 0).any(1) | (torch.arange(len(ya)) % NONE_THINNING == 0)
    x, y, p = torch.cat([x, xa[keep]]), torch.cat([y, ya[keep]]), torch.cat([p, pa[keep]])
    net = Net(len(classes))
    flat = torch.cat([s[0] for s in [(torch.tensor(q[0], dtype=torch.float32),) for q in seqs]])
    net.mean.copy_(flat.mean(0))
    net.std.copy_(flat.std(0).clamp_min(1e-3))
    counts = torch.bincount(y[y >= 0], minlength=len(classes)).float().clamp_min(1)
    # Strike frames are rare: weight classes by 1/sqrt(frequency), none = 1.
    weight = (counts[0] / counts).sqrt() if CLASS_WEIGHT == "sqrt" else torch.ones(len(classes))
    weight[0] = 1
    ce = nn.CrossEntropyLoss(weight=weight, ignore_index=-1)
    opt = torch.optim.Adam(net.parameters(), lr=2e-3, weight_decay=1e-5)
    g = torch.Generator().manual_seed(seed)
    batch = 32
    for ep in range(epochs):
        perm = torch.randperm(len(x), generator=g)
        tot = 0.0
        for b in range(0, len(x), batch):
            idx = perm[b:b + batch]
            logits, prog = net(x[idx])
            yy, pp = y[idx], p[idx]
            loss = ce(logits.reshape(-1, len(classes)), yy.reshape(-1))
            mask = (yy > 0) & (pp >= 0)
            if mask.any():
                loss = loss + 4.0 * ((prog[mask] - pp[mask]) ** 2).mean()
            opt.zero_grad()
            loss.backward()
            opt.step()
            tot += loss.item() * len(idx)
        if log and (ep % 4 == 3 or ep == epochs - 1):
            print(f"    epoch {ep + 1}/{epochs} loss {tot / len(x):.4f}", file=sys.stderr)
    return net


def impact_points(seqs, classes):
    """Per class: the mean input position at full extension (progress 1 frames' last)."""
    pts = np.zeros((len(classes), 3))
    for c in range(1, len(classes)):
        hits = []
        for x, y, p in seqs:
            for i in range(len(y)):
                if y[i] == c and (i + 1 == len(y) or y[i + 1] != c):
                    hits.append(x[i, :3])
        if hits:
            pts[c] = np.mean(hits, axis=0)
    return pts


# ---- model file ------------------------------------------------------------------------------


def b64(a):
    return base64.b64encode(np.ascontiguousarray(a, dtype="<f4").tobytes()).decode("ascii")


def tensor_line(name, a):
    a = np.asarray(a, dtype=np.float32)
    return f"tensor {name} {' '.join(str(d) for d in a.shape)} {b64(a)}"


def format_model(nets, note, settings):
    body = [f"note {note}"]
    for k, v in settings.items():
        body.append(f"setting {k} {v!r}")
    for kind, (net, classes, impact) in nets.items():
        hidden = net.conv1.out_channels
        body.append(f"net {kind} classes {len(classes)} {' '.join(classes)} input {INPUT} hidden {hidden} "
                    f"kernel1 {K1} dilation1 {D1} kernel2 {K2} dilation2 {D2}")
        sd = {k: v.detach().cpu().numpy() for k, v in net.state_dict().items()}
        body.append(tensor_line("mean", sd["mean"]))
        body.append(tensor_line("std", sd["std"]))
        body.append(tensor_line("conv1_weight", sd["conv1.weight"]))
        body.append(tensor_line("conv1_bias", sd["conv1.bias"]))
        body.append(tensor_line("conv2_weight", sd["conv2.weight"]))
        body.append(tensor_line("conv2_bias", sd["conv2.bias"]))
        body.append(tensor_line("out_weight", sd["out.weight"][:, :, 0]))
        body.append(tensor_line("out_bias", sd["out.bias"]))
        body.append(tensor_line("impact", impact))
    body.append("end")
    text = "\n".join(body) + "\n"
    return f"{MAGIC} {VERSION}\nchecksum fnv1a64 {fnv1a64(text.encode()):016x}\n{text}"


def write_atomically(path, text):
    d = os.path.dirname(os.path.abspath(path))
    os.makedirs(d, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=d, prefix=".tmp-")
    with os.fdopen(fd, "w") as f:
        f.write(text)
    os.chmod(tmp, 0o644)
    os.replace(tmp, path)


def settings_of(ds):
    fe = ds["frontend"]
    return {"loop_hz": float(ds["loop_hz"]), "smoothing_tau_s": float(fe["smoothing_tau_s"]),
            "heading_tau_s": float(fe["heading_tau_s"]), "height_tau_s": float(fe["height_tau_s"]),
            "velocity_weight": float(ds["velocity_weight"]), "max_gap_s": float(fe["max_gap_s"]),
            "begin_probability": BEGIN_PROBABILITY, "begin_progress": 0.0, "end_frames": 3.0, "confirm_frames": 1.0,
            "min_speed": 0.0}


def train_model(ds, recordings, note, seed, epochs, log=True):
    nets = {}
    rng = np.random.default_rng(seed)
    for kind in ("hand", "foot"):
        classes = ds["classes"][kind]
        real = sequences(ds, recordings, kind)
        aug = [augment(s, rng, ds["velocity_weight"], ds["loop_hz"]) for s in real for _ in range(AUGMENT)]
        if log:
            strikes = sum(int((s[1] > 0).sum()) for s in real)
            print(f"  {kind}: {len(real)} sequences ({strikes} strike loops) + {len(aug)} augmented copies",
                  file=sys.stderr)
        net = train_net(real + aug, len(aug), classes, seed, epochs, log)
        nets[kind] = (net, classes, impact_points(real, classes))
    return format_model(nets, note, settings_of(ds))


LICENCE = ("derived from CMU mocap (CMU terms, acknowledgement requested) and HDM05 (CC BY-SA 3.0, "
           "Mueller et al. 2007): keep this licence when distributing")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dataset", help="kumite-recognise dataset output (JSON)")
    ap.add_argument("--out", help="model file to write (.klearn), trained on every recording of the dataset")
    ap.add_argument("--eval-dir", help="write the cross-actor fold models here")
    ap.add_argument("--fixture", help="write the C++ inference fixture (SYNTHETIC weights) here")
    ap.add_argument("--seed", type=int, default=14)
    ap.add_argument("--epochs", type=int, default=12)
    ap.add_argument("--class-weight", choices=["sqrt", "none"], default="none",
                    help="strike classes weighted by sqrt(none loops / class loops), or all 1 (default: fewer false triggers)")
    ap.add_argument("--none-thinning", type=int, default=3,
                    help="keep one in N augmented chunks that hold no strike loop (1 = all)")
    ap.add_argument("--begin-probability", type=float, default=0.8,
                    help="the model's begin threshold on a strike class's probability (kumite-recognise eval can override it)")
    a = ap.parse_args()
    torch.set_num_threads(1)
    torch.use_deterministic_algorithms(True)
    global CLASS_WEIGHT, BEGIN_PROBABILITY, NONE_THINNING
    NONE_THINNING = a.none_thinning
    CLASS_WEIGHT = a.class_weight
    BEGIN_PROBABILITY = a.begin_probability
    if a.fixture:
        return write_fixture(a.fixture, a.seed)
    if not a.dataset or not (a.out or a.eval_dir):
        ap.error("--dataset with --out and/or --eval-dir, or --fixture")
    with open(a.dataset) as f:
        ds = json.load(f)
    recs = ds["recordings"]
    if any(not r.get("trainable", False) for r in recs):
        sys.exit(f"{a.dataset}: a recording is not trainable (development-only data is never trained on)")
    if a.out:
        print(f"model: all {len(recs)} recordings", file=sys.stderr)
        text = train_model(ds, recs, f"learned (Touche) recogniser trained on {os.path.basename(ds.get('motions', 'motions.toml'))}"
                           f": {len(recs)} recordings, {AUGMENT} augmented copies each (seed {a.seed}, {a.epochs} epochs); "
                           + LICENCE, a.seed, a.epochs)
        write_atomically(a.out, text)
        print(json.dumps({"out": a.out, "bytes": len(text)}))
    if a.eval_dir:
        jobs = []
        actors = sorted({r["actor"] for r in recs if r["strikes"] > 0})
        for held in actors:
            jobs.append((f"fold-{held}.klearn", [r for r in recs if r["actor"] != held], f"fold without actor {held}"))
        for r in recs:
            if r["negative"]:
                jobs.append((f"without-{r['name']}.klearn", [o for o in recs if o is not r], f"all but {r['name']}"))
        jobs.append(("all.klearn", recs, "all annotated actors"))
        for name, tr, note in jobs:
            print(f"{name}: {note}", file=sys.stderr)
            write_atomically(os.path.join(a.eval_dir, name), train_model(ds, tr, note, a.seed, a.epochs))
        print(json.dumps({"eval_dir": a.eval_dir, "models": [j[0] for j in jobs]}))


# ---- fixture: C++ inference must match torch --------------------------------------------------


def write_fixture(out_dir, seed):
    """A SYNTHETIC-weights model (random, hidden 8) and windows with torch's outputs."""
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    nets = {}
    for kind, classes in (("hand", ["none", "straight_punch"]), ("foot", ["none", "front_kick", "side_kick"])):
        net = Net(len(classes), hidden=8)
        net.mean.copy_(torch.tensor(rng.normal(0, 0.1, INPUT), dtype=torch.float32))
        net.std.copy_(torch.tensor(rng.uniform(0.2, 1.0, INPUT), dtype=torch.float32))
        nets[kind] = (net, classes, rng.normal(0, 0.3, (len(classes), 3)))
    text = format_model(nets, "SYNTHETIC random weights: the C++ inference test fixture (tests only)",
                        {"loop_hz": 60.0, "smoothing_tau_s": 0.01, "heading_tau_s": 0.3, "height_tau_s": 3.0,
                         "velocity_weight": 0.15, "max_gap_s": 0.1, "begin_probability": 0.5,
                         "begin_progress": 0.0, "end_frames": 3.0, "confirm_frames": 1.0, "min_speed": 0.0})
    write_atomically(os.path.join(out_dir, "learned_fixture.klearn"), text)
    # Reload the weights as the file holds them (float32), then run torch on random windows.
    cases = []
    for kind, (net, classes, _) in nets.items():
        for _ in range(4):
            w = rng.normal(0, 0.5, (WINDOW, INPUT)).astype(np.float32)
            with torch.no_grad():
                logits, prog = net(torch.tensor(w)[None])
                prob = torch.softmax(logits[0, -1], 0)
            cases.append({"kind": kind, "window": w.tolist(), "probabilities": prob.tolist(),
                          "progress": float(prog[0, -1])})
    write_atomically(os.path.join(out_dir, "learned_fixture.json"),
                     json.dumps({"what": "SYNTHETIC: torch's outputs of learned_fixture.klearn on random windows "
                                 "(window[0] oldest, 16 loops x 6 inputs)", "cases": cases}) + "\n")
    print(json.dumps({"fixture": out_dir, "cases": len(cases)}))


if __name__ == "__main__":
    main()
