#!/usr/bin/env python3
"""Checks that the app's public headers do not include the fighter's tunables or behaviour.

Adding a tunable (content/tunables.hpp, planner.hpp) or changing the fighter's behaviour
(behaviour.hpp, fighter.hpp) should recompile the units that use them, not every unit of the app
that includes its config or installation: app/config.hpp holds the tunables in Boxed<> and
app/installation.hpp takes the fighter's types from content/fighter_types.hpp. Before that, a
new tunable recompiled 91 of the build's 216 objects, twice in CI (release and sanitizers), and
CI ran over its 30 minutes.

  scripts/check-header-fanout.py BUILD_DIR SOURCE_DIR

Preprocesses each header under app/include/kumite/app/ and app/src/ alone (the compiler's -M,
with the flags compile_commands.json gives app/src/core/installation.cpp; a header it cannot find
fails the check rather than hiding what that header would include) and lists what it includes.
Exit 0: none includes the headers below. Exit 1: one line per header that does, naming them.
"""
import importlib.util
import os
import shlex
import subprocess
import sys

# Reading the two arguments and compile_commands.json: as scripts/check-portable-build.py does.
_spec = importlib.util.spec_from_file_location("check_portable_build",
                                               os.path.join(os.path.dirname(os.path.abspath(__file__)), "check-portable-build.py"))
portable = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(portable)

FORBIDDEN = [
    "kumite/content/tunables.hpp",
    "kumite/content/planner.hpp",
    "kumite/content/fighter.hpp",
    "kumite/content/behaviour.hpp",
]
REFERENCE = "app/src/core/installation.cpp"


def flags_of(entry):
    args = shlex.split(entry["command"]) if "command" in entry else list(entry["arguments"])
    out, i = [], 0
    compiler = None
    while i < len(args):
        a = args[i]
        if compiler is None and not a.startswith("-") and "ccache" not in os.path.basename(a):
            compiler = a
        if a in ("-isystem", "-I", "-D", "-include"):
            out += [a, args[i + 1]]
            i += 2
            continue
        if a.startswith(("-I", "-D", "-std=", "-isystem")):
            out.append(a)
        i += 1
    return compiler, out


def main():
    got = portable.build_and_commands(sys.argv, "usage: scripts/check-header-fanout.py BUILD_DIR SOURCE_DIR")
    if got is None:
        return 1
    _, source, commands, entries = got
    ref = [e for e in entries if os.path.realpath(e["file"]) == os.path.join(source, REFERENCE)]
    if not ref:
        print(f"{commands}: no compile command for {REFERENCE}", file=sys.stderr)
        return 1
    compiler, flags = flags_of(ref[0])
    headers = []  # (as named in messages, absolute path)
    for folder in (os.path.join("app", "include", "kumite", "app"), os.path.join("app", "src")):
        for root, _, files in os.walk(os.path.join(source, folder)):
            for f in sorted(files):
                if f.endswith(".hpp"):
                    path = os.path.join(root, f)
                    headers.append((os.path.relpath(path, source), path))
    headers.sort()
    bad = 0
    for h, path in headers:
        r = subprocess.run([compiler, "-x", "c++", "-M", *flags, "-"], input=f'#include "{path}"\n',
                           capture_output=True, text=True, cwd=ref[0]["directory"])
        if r.returncode != 0:
            print(f"{h}: the preprocessor failed: {r.stderr.strip().splitlines()[:1]}")
            bad += 1
            continue
        deps = r.stdout.replace("\\\n", " ").split()
        found = [f for f in FORBIDDEN if any(d.endswith(f) for d in deps)]
        if found:
            print(f"{h}: includes {', '.join(found)} (include content/fighter_types.hpp; "
                  "hold tunables in Boxed<>)")
            bad += 1
    if not bad:
        print(f"{len(headers)} app headers: none includes {', '.join(os.path.basename(f) for f in FORBIDDEN)}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
