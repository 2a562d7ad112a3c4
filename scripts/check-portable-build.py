#!/usr/bin/env python3
"""Checks that a build compiles the same objects in any clone, so that ccache serves CI's.

CI builds a fresh clone in a folder of its own. ccache runs with base_dir at the checkout and
hash_dir off (CMakeLists.txt), so an object is served from the cache when its command and
sources are the same up to the checkout's folder, except where a -D define compiles the
checkout's absolute path in (the object then really differs, and every such source missed the
cache in every CI run). Only the sources allowed below may do that.

  scripts/check-portable-build.py BUILD_DIR SOURCE_DIR

Exit 0: no other source has such a define, and the build's compile commands go through ccache
with base_dir at SOURCE_DIR (where ccache is installed). Exit 1: one line per offending source.
"""
import json
import os
import shlex
import shutil
import sys

# The sources whose object names this checkout's folders on purpose (one each, small).
ALLOWED = {"content/src/content_dir.cpp", "generated/build_paths.cpp"}


def build_and_commands(argv, usage):
    """(BUILD_DIR, SOURCE_DIR, compile_commands.json's path, its entries) from `argv` (the script's
    two arguments), or None after one line on stderr: the usage, or why the file cannot be read.
    Shared with scripts/check-header-fanout.py."""
    if len(argv) != 3:
        print(usage, file=sys.stderr)
        return None
    build, source = os.path.realpath(argv[1]), os.path.realpath(argv[2])
    commands = os.path.join(build, "compile_commands.json")
    try:
        with open(commands) as f:
            entries = json.load(f)
    except (OSError, ValueError) as e:
        print(f"{commands}: cannot read it: {e}", file=sys.stderr)
        return None
    return build, source, commands, entries


def main():
    got = build_and_commands(sys.argv, "usage: scripts/check-portable-build.py BUILD_DIR SOURCE_DIR")
    if got is None:
        return 1
    build, source, commands, entries = got
    bad = []
    for e in entries:
        path = os.path.realpath(e["file"])
        rel = os.path.relpath(path, build) if path.startswith(build + os.sep) else os.path.relpath(path, source)
        if rel in ALLOWED:
            continue
        for arg in shlex.split(e["command"]):
            if arg.startswith("-D") and (source in arg or build in arg):
                bad.append(f"{rel}: {arg}: an absolute path compiled in (use cmake/build_paths)")
    if shutil.which("ccache"):
        try:
            with open(os.path.join(build, "CMakeFiles", "rules.ninja")) as f:
                ninja = f.read()
        except OSError:
            ninja = None  # another generator: its rules are not checked
        if ninja is not None and f"CCACHE_BASEDIR={source}" not in ninja:
            bad.append(f"{build}/CMakeFiles/rules.ninja: compiles without CCACHE_BASEDIR={source} (CMakeLists.txt's launcher)")
    for line in bad:
        print(line, file=sys.stderr)
    if not bad:
        print(f"{len(entries)} compile commands: none compiles the checkout's path in but {sorted(ALLOWED)}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
