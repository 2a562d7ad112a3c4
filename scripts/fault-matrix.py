#!/usr/bin/env python3
"""The fault matrix: a fault takes out the feature that needs the broken input and nothing else.

Builds a site (an installation file and a copy of every input it reads) in a temporary folder,
then for each input the show depends on -- each camera's images, the camera recording, the
calibration, the poses file, the recognition model, each character file, the motion database,
the orders script, the health report's folder -- and each fault -- missing, truncated (its
first half kept), corrupted (its middle byte's bits flipped), unreadable -- runs the built
`kumite` on the broken copy as a technician would (headless, 90 frames) and reads what a
person reads: the exit status, the console lines (stderr), frames.jsonl and the health report.

Every feature is judged from those outputs alone, independently of the code that makes them:
  walls        every frame logged (the walls drawn), exit status 0
  head         the head live (tracked) in at least one frame
  fighter      the fighter present in the frames
  characters   all five characters in the fighter (none "left out")
  orders       the orders script's punch accepted (an `order` event)
  recognition  strike recognition running (its console line), poses site only
  health       the health report written

The rule checked: every feature that does not need the broken input works as in the
unbroken baseline; a feature that stopped is said on the console (stderr) -- a few lines at
most (at most one per 10 frames: a rate-limited summary may repeat on a loaded machine), not one
per frame --, in the log's problems and in the health report's problems (the
report itself excepted when it is the broken input). Exit 0 when the rule holds in every case.

  scripts/fault-matrix.py --build build [--out DIR] [--markdown FILE] [--only NAME]

Unreadable: as root no permission keeps a file from its reader, so there a folder of the
same name stands in its place (said in the table); as another user, chmod 000.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FRAMES = 90
FEATURES = ["walls", "head", "fighter", "characters", "orders", "recognition", "health"]
CHARACTERS = ["kenji", "mei", "bruno", "aiko", "viktor"]
IS_ROOT = os.geteuid() == 0


def site_toml(kind):
    """The installation file of the matrix's site: the shipped demo's walls, keys and fighter,
    small frames, a health report every 0.1 s; kind "cameras" (the camera recording) or
    "poses" (a mocap visitor with gloves, and strike recognition)."""
    text = (ROOT / "config" / ("demo.toml" if kind == "cameras" else "demo-poses.toml")).read_text()
    out = []
    section = ""
    for line in text.splitlines():
        s = line.strip()
        if s.startswith("["):
            section = s
        key = s.split("=")[0].strip() if "=" in s and not s.startswith("#") else ""
        if key == "data_dir":
            line = 'data_dir = "data"'
        elif key == "bvh":
            name = s.split("/")[-1].split('"')[0]
            line = f'bvh = "characters/{name}"'
        elif key == "recording_preload":
            line = "recording_preload = 0"
        elif key == "realtime_priority":
            line = "realtime_priority = 0"
        elif key == "script" and section == "[orders]":
            line = 'script = "orders.csv"'
        elif key == "poses":
            line = 'poses = "visitor.poses.csv"'
        elif key == "model":
            line = 'model = "models/strikes.krec"'
        out.append(line)
    out.append('\n[health]\nfile = "health/health.json"\ninterval_s = 0.1\n')
    return "\n".join(out) + "\n"


def make_site(dst, build, kind):
    dst.mkdir(parents=True)
    (dst / "site.toml").write_text(site_toml(kind))
    shutil.copytree(ROOT / "config" / "rig", dst / "rig")
    shutil.copy(ROOT / "config" / "tracking.toml", dst / "tracking.toml")
    (dst / "characters").mkdir()
    for c in CHARACTERS:
        shutil.copy(ROOT / "content" / "characters" / f"{c}.bvh", dst / "characters" / f"{c}.bvh")
    (dst / "data").mkdir()
    shutil.copy(build / "demo" / "fighter.kdb", dst / "data" / "fighter.kdb")
    if kind == "cameras":
        shutil.copytree(build / "demo" / "recording", dst / "data" / "recording")
    else:
        shutil.copy(ROOT / "config" / "visitor-135_06.poses.csv", dst / "visitor.poses.csv")
    (dst / "models").mkdir()
    shutil.copy(ROOT / "recognition" / "models" / "strikes.krec", dst / "models" / "strikes.krec")
    # An order the frames reach: 0.1 s after the head is tracked (or the start, without it).
    (dst / "orders.csv").write_text("time_s,order\n0.1,punch_right\n")
    (dst / "health").mkdir()


# input name -> (site, path in the site, the features that need it)
def inputs():
    rows = []
    for cam in range(4):
        rows.append((f"camera cam{cam}", "cameras", f"data/recording/cam{cam}", set()))
    rows += [
        ("camera recording (frames.csv)", "cameras", "data/recording/frames.csv", {"head"}),
        ("calibration", "cameras", "rig/calibration.yaml", {"head"}),
        ("poses file", "poses", "visitor.poses.csv", {"head", "recognition"}),
        ("recognition model", "poses", "models/strikes.krec", {"recognition"}),
    ]
    for c in CHARACTERS:
        rows.append((f"character {c}.bvh", "cameras", f"characters/{c}.bvh", {"characters"}))
    rows += [
        ("motion database", "cameras", "data/fighter.kdb", {"fighter", "characters", "orders"}),
        ("orders script", "cameras", "orders.csv", {"orders"}),
        ("health report's folder", "cameras", "health", {"health"}),
    ]
    return rows


FAULTS = ["missing", "truncated", "corrupted", "unreadable"]


def files_of(p):
    return sorted(f for f in p.rglob("*") if f.is_file()) if p.is_dir() else [p]


def apply_fault(p, fault):
    """Breaks `p` (a file, or every file of a folder) in place; returns a note, or None when the
    fault does not apply (a folder is neither truncated nor corrupted as a whole)."""
    if fault == "missing":
        shutil.rmtree(p) if p.is_dir() else p.unlink()
        return "removed"
    if fault in ("truncated", "corrupted"):
        if p.name == "health":
            return None
        for f in files_of(p):
            b = bytearray(f.read_bytes())
            if fault == "truncated":
                b = b[: len(b) // 2]
            elif b:
                b[len(b) // 2] ^= 0xFF
            f.write_bytes(bytes(b))
        return "each file" if p.is_dir() else ""
    if fault == "unreadable":
        if IS_ROOT:
            # Root reads through any permission: a folder stands where the file was (a file where
            # the folder was), which no reader can take for it.
            was_dir = p.is_dir()
            shutil.rmtree(p) if was_dir else p.unlink()
            if was_dir:
                p.write_text("not a folder\n")
                return "root: a file in its place"
            p.mkdir()
            return "root: a folder in its place"
        os.chmod(p, 0)
        return "chmod 000"
    raise ValueError(fault)


def observe(site, out, kumite, timeout_s=120):
    """Runs the installation on the site and reads what a person reads."""
    env = dict(os.environ)
    env.pop("DISPLAY", None)
    env.pop("WAYLAND_DISPLAY", None)
    cmd = [str(kumite), "--config", str(site / "site.toml"), "--headless", "--simulated-time",
           "--frames", str(FRAMES), "--save-every", "0", "--resolution", "64x36", "--out", str(out)]
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s, env=env, errors="replace")
        rc, console = p.returncode, p.stdout + p.stderr
    except subprocess.TimeoutExpired as e:
        rc, console = "timeout", (e.stdout or b"").decode(errors="replace") + (e.stderr or b"").decode(errors="replace")
    frames = []
    log = out / "frames.jsonl"
    if log.is_file():
        for line in log.read_text(errors="replace").splitlines():
            try:
                frames.append(json.loads(line))
            except json.JSONDecodeError:
                pass
    health = None
    hf = site / "health" / "health.json"
    if hf.is_file():
        try:
            health = json.loads(hf.read_text())
        except json.JSONDecodeError:
            health = {"unreadable": True}
    last = frames[-1] if frames else {}
    problems = last.get("console", {}).get("problems", [])
    works = {
        "walls": rc == 0 and len(frames) == FRAMES,
        "head": any(f.get("head", {}).get("live") for f in frames),
        "fighter": any(f.get("fighter", {}).get("state") not in (None, "none") for f in frames),
        "characters": any(f.get("fighter", {}).get("present") for f in frames) and
                      not any("left out" in p for p in problems),
        "orders": any(e.get("type") == "order" for f in frames for e in f.get("events", [])),
        "recognition": any(f.get("console", {}).get("recognition", "").startswith("strike recognition") and
                           "off" not in f.get("console", {}).get("recognition", "") for f in frames),
        "health": health is not None and "unreadable" not in health,
    }
    lines = [l for l in console.splitlines() if "[error]" in l or "[warning]" in l]
    return {"rc": rc, "frames": len(frames), "works": works, "problems": problems,
            "health_problems": (health or {}).get("problems", []), "console_lines": lines, "console": console}


def said(obs, needle, health_broken):
    """How the fault was said: console lines naming it, the log's problems, the health report's."""
    n_console = sum(1 for l in obs["console_lines"] if needle in l)
    in_log = any(needle in p for p in obs["problems"])
    in_health = health_broken or any(needle in p for p in obs["health_problems"])
    return n_console, in_log, in_health


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", default=str(ROOT / "build"), help="build folder (bin/kumite, demo/)")
    ap.add_argument("--out", help="folder for the report (fault-matrix.json) and each run's outputs")
    ap.add_argument("--markdown", help="also write the table as Markdown here")
    ap.add_argument("--only", help="only inputs whose name contains this")
    a = ap.parse_args()
    build = Path(a.build).resolve()
    kumite = build / "bin" / "kumite"
    if not kumite.is_file() or not (build / "demo" / "fighter.kdb").is_file():
        print(f"fault-matrix: {kumite} or {build}/demo/fighter.kdb missing (scripts/setup.sh makes them): skipped", file=sys.stderr)
        return 77
    work = Path(tempfile.mkdtemp(prefix="kumite-faults-"))
    out_dir = Path(a.out).resolve() if a.out else work / "report"
    out_dir.mkdir(parents=True, exist_ok=True)
    pristine = {k: work / f"pristine-{k}" for k in ("cameras", "poses")}
    for k, d in pristine.items():
        make_site(d, build, k)
    baseline = {}
    for k, d in pristine.items():
        site = work / f"run-{k}-baseline"
        shutil.copytree(d, site)
        baseline[k] = observe(site, out_dir / f"{k}-baseline", kumite)
        shutil.rmtree(site)
    expected_base = {"cameras": {f for f in FEATURES if f != "recognition"}, "poses": set(FEATURES)}
    failures = []
    for k, b in baseline.items():
        broken = sorted(f for f in expected_base[k] if not b["works"][f])
        if broken:
            failures.append(f"baseline {k}: {', '.join(broken)} not working:\n{b['console'][-3000:]}")
    rows = []
    for name, kind, rel, needs in inputs():
        if a.only and a.only not in name:
            continue
        for fault in FAULTS:
            site = work / "run"
            shutil.rmtree(site, ignore_errors=True)
            shutil.copytree(pristine[kind], site, symlinks=True)
            note = apply_fault(site / rel, fault)
            if note is None:
                continue
            run_out = out_dir / f"{kind}-{rel.replace('/', '_')}-{fault}"
            obs = observe(site, run_out, kumite)
            if fault == "unreadable" and not IS_ROOT:
                os.chmod(site / rel, 0o755)
            base = baseline[kind]["works"]
            relevant = expected_base[kind]
            lost = sorted(f for f in relevant if base[f] and not obs["works"][f])
            collateral = [f for f in lost if f not in needs]
            needle = Path(rel).name
            n_console, in_log, in_health = said(obs, needle, "health" in needs)
            problems = []
            if collateral:
                problems.append(f"took out {', '.join(collateral)}, which do not need it")
            if lost and not (n_console >= 1 and in_log and in_health):
                problems.append(f"stopped {', '.join(lost)} without saying so everywhere "
                                f"(console lines {n_console}, log {in_log}, health {in_health})")
            # Said, not repeated every frame: a source's own rate-limited summary (the recording's
            # "N more images skipped in the last 5 s") may come again on a loaded machine.
            if n_console > max(3, FRAMES // 10):
                problems.append(f"said {n_console} times on the console in {FRAMES} frames (not once per frame or so)")
            if not lost and obs["rc"] != 0:
                problems.append(f"exit status {obs['rc']}")
            row = {"input": name, "fault": fault, "note": note, "rc": obs["rc"], "frames": obs["frames"],
                   "stopped": lost, "kept": sorted(f for f in relevant if obs["works"][f]),
                   "console": [l.split("] ", 2)[-1].replace(str(site), "SITE")
                               for l in obs["console_lines"] if needle in l][:2],
                   "problems_in_log": [p.replace(str(site), "SITE") for p in obs["problems"] if needle in p][:2],
                   "in_health_report": in_health, "violations": problems}
            rows.append(row)
            status = "ok" if not problems else "FAIL: " + "; ".join(problems)
            print(f"{name:32s} {fault:10s} rc={obs['rc']} stopped={','.join(lost) or '-':24s} {status}", flush=True)
            if problems:
                failures.append(f"{name} {fault}: {'; '.join(problems)}\n{obs['console'][-2000:]}")
    shutil.rmtree(work / "run", ignore_errors=True)
    report = {"frames_per_run": FRAMES, "baseline": {k: v["works"] for k, v in baseline.items()}, "runs": rows,
              "root": IS_ROOT, "violations": len(failures)}
    tmp = out_dir / ".fault-matrix.json.tmp"
    tmp.write_text(json.dumps(report, indent=1) + "\n")
    tmp.replace(out_dir / "fault-matrix.json")
    if a.markdown:
        md = ["| input | fault | stops | keeps working | the console says (first line naming it) | log, health | exit |",
              "|---|---|---|---|---|---|---|"]
        for r in rows:
            said_line = (r["console"][0] if r["console"] else "—").replace("|", "\\|")
            if len(said_line) > 100:
                said_line = said_line[:97] + "..."
            fault = r["fault"] + (f" ({r['note']})" if r["note"].startswith("root") else "")
            log_health = ("yes" if r["problems_in_log"] else "no") + ", " + ("yes" if r["in_health_report"] else "no")
            if not r["stopped"] and not r["problems_in_log"]:
                log_health = "—"
            md.append(f"| {r['input']} | {fault} | {', '.join(r['stopped']) or 'nothing'} | "
                      f"{', '.join(r['kept'])} | {said_line} | {log_health} | {r['rc']} |")
        Path(a.markdown).write_text("\n".join(md) + "\n")
    shutil.rmtree(work, ignore_errors=True) if not a.out else None
    print(f"fault matrix: {len(rows)} runs, {len(failures)} violations; report {out_dir / 'fault-matrix.json'}")
    for f in failures:
        print("VIOLATION " + f, file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
