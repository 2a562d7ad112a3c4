#!/usr/bin/env bash
# shellcheck disable=SC2016  # the $ and ${X} in single quotes are the point: they must reach kumite as written
# scripts/install-service.sh writes every path and value into the unit the way systemd reads it
# back: checkouts, configs, data folders and kumite binaries in folders whose names hold a space,
# '&', '%', '$', '"', a backslash or a quote; a newline or another control character refused.
#
#   bash tests/scripts/test-install-service.sh                       # the checkout's script
#   INSTALL_SERVICE=FILE bash tests/scripts/test-install-service.sh  # another version of it
#
# Each case runs the script (--dry-run, a fake kumite) from a copy of the checkout's script and
# unit template in a folder named for the case, and reads the unit back with an implementation of
# systemd's rules of its own (a python3 snippet below: specifiers, ExecStart='s quoting, C escapes
# and $ variables, Environment= words, file:// URLs, line continuations). Where systemd-analyze
# is installed, `systemd-analyze verify` checks the unit as well (it parses every setting and
# finds the executable). Prints "N passed, M failed"; exits 1 when a check failed.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
SCRIPT=${INSTALL_SERVICE:-$ROOT/scripts/install-service.sh}
PYTHON3=${PYTHON3:-python3}
[[ -f "$SCRIPT" ]] || { echo "test-install-service.sh: no script $SCRIPT" >&2; exit 1; }
command -v "$PYTHON3" >/dev/null || { echo "test-install-service.sh: needs python3" >&2; exit 1; }
PYTHON3=$("$PYTHON3" -c 'import sys; print(sys.executable)')   # past a slow launcher (pyenv's shim)
ANALYZE=$(command -v systemd-analyze || true)

T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
PASSED=0 FAILED=0
pass() { PASSED=$((PASSED + 1)); }
fail() { FAILED=$((FAILED + 1)); echo "FAIL: $*" >&2; }
shown() { local s="" w; for w in "$@"; do s+=" $(printf '%q' "$w")"; done; echo "${s# }"; }

cat >"$T/read_unit.py" <<'PY'
# read_unit.py UNIT SETTING: the values systemd reads from SETTING=, each followed by a NUL.
# ExecStart: the argv; Environment: KEY=VALUE words; Documentation: file:// URLs' paths;
# others: the value. Anything systemd would warn about or read differently is an error here.
import sys, re, urllib.parse

def fail(msg):
    sys.stderr.write(msg + "\n")
    sys.exit(2)

def specifiers(s):  # %% is %, any other specifier is not expected in this unit
    out, i = [], 0
    while i < len(s):
        if s[i] == "%":
            if s[i + 1:i + 2] != "%":
                fail("specifier %" + s[i + 1:i + 2] + " in " + repr(s))
            out.append("%"); i += 2
        else:
            out.append(s[i]); i += 1
    return "".join(out)

ESCAPES = {"a": "\a", "b": "\b", "f": "\f", "n": "\n", "r": "\r", "t": "\t", "v": "\v",
           "\\": "\\", '"': '"', "'": "'", "s": " "}

def words(s):  # split on whitespace; "..." and '...' quote; C escapes in and out of quotes
    out, i, n = [], 0, len(s)
    while True:
        while i < n and s[i] in " \t\n\r":
            i += 1
        if i >= n:
            return out
        w, quote, bare = [], None, True
        while i < n:
            c = s[i]
            if c == "\\":
                e = s[i + 1:i + 2]
                if e in ESCAPES:
                    w.append(ESCAPES[e]); i += 2
                elif e == "x" and re.fullmatch(r"[0-9a-fA-F]{2}", s[i + 2:i + 4]):
                    w.append(chr(int(s[i + 2:i + 4], 16))); i += 4
                else:
                    fail("unknown escape \\" + e + " in " + repr(s))
                bare = False
            elif quote:
                if c == quote:
                    quote = None
                else:
                    w.append(c)
                i += 1
            elif c in "\"'":
                quote, bare = c, False; i += 1
            elif c in " \t\n\r":
                break
            else:
                w.append(c); i += 1
        if quote:
            fail("unterminated quote in " + repr(s))
        w = "".join(w)
        if bare and w == ";":
            fail("a bare ; (a second command) in " + repr(s))
        out.append(w)

def variables(s):  # ExecStart='s arguments: $$ is $, $NAME and ${NAME} are variables
    out, i = [], 0
    while i < len(s):
        if s[i] == "$":
            nxt = s[i + 1:i + 2]
            if nxt == "$":
                out.append("$"); i += 2; continue
            if nxt == "{" or re.match(r"[A-Za-z0-9_]", nxt):
                fail("an environment variable $" + nxt + "... in " + repr(s))
        out.append(s[i]); i += 1
    return "".join(out)

def settings(path):
    text = open(path, encoding="utf-8", errors="surrogateescape").read()
    lines, cont = [], None
    for raw in text.split("\n"):
        line = raw.strip()
        if cont is None and (not line or line[0] in "#;"):
            continue
        if line.endswith("\\"):  # a continuation: the backslash becomes a space
            cont = (cont or "") + line[:-1] + " "
            continue
        lines.append((cont or "") + line)
        cont = None
    if cont is not None:
        lines.append(cont)
    found = {}
    for line in lines:
        if line.startswith("["):
            continue
        if "=" not in line:
            fail("not a setting: " + repr(line))
        key, value = line.split("=", 1)
        found.setdefault(key.strip(), []).append(value.strip())
    return found

unit, setting = sys.argv[1], sys.argv[2]
values = settings(unit).get(setting, [])
got = []
if setting == "ExecStart":
    if len(values) != 1:
        fail("%d ExecStart= lines" % len(values))
    if values[0][:1] in "@-:+!":
        fail("ExecStart= with a prefix: " + repr(values[0]))
    argv = words(specifiers(values[0]))
    if not argv or not argv[0].startswith("/"):
        fail("ExecStart= without an absolute executable: " + repr(values[0]))
    got = argv[:1] + [variables(a) for a in argv[1:]]
elif setting == "Environment":
    for v in values:
        for w in words(specifiers(v)):
            if not re.match(r"[A-Za-z_][A-Za-z0-9_]*=", w):
                fail("not an environment assignment: " + repr(w))
            got.append(w)
elif setting == "Documentation":
    for v in values:
        for w in words(specifiers(v)):
            if not w.startswith("file://") or not w.isascii() or re.search(r"\s", w):
                fail("not a file:// URL systemd takes: " + repr(w))
            b = urllib.parse.unquote_to_bytes(w[len("file://"):])
            got.append(b.decode("utf-8", errors="surrogateescape"))
else:
    if len(values) != 1:
        fail("%d %s= lines" % (len(values), setting))
    got = [specifiers(values[0])]
    if setting == "WorkingDirectory" and not got[0].startswith("/"):
        fail("WorkingDirectory= not absolute: " + repr(values[0]))
sys.stdout.buffer.write(b"".join(g.encode("utf-8", errors="surrogateescape") + b"\0" for g in got))
PY

# expect WHAT UNIT SETTING VALUE...: SETTING= in UNIT reads back as exactly VALUE...
expect() {
  local what=$1 unit=$2 setting=$3 got
  shift 3
  if ! "$PYTHON3" -S "$T/read_unit.py" "$unit" "$setting" >"$T/got" 2>"$T/why"; then
    fail "$what: $setting= does not read back: $(head -1 "$T/why") (line: $(grep -m1 "^$setting=" "$unit" || true))"
    return
  fi
  if [[ $# -eq 0 ]]; then : >"$T/want"; else printf '%s\0' "$@" >"$T/want"; fi
  if cmp -s "$T/got" "$T/want"; then pass; return; fi
  mapfile -d '' got <"$T/got"
  fail "$what: $setting= reads back as [$(shown ${got[@]+"${got[@]}"})], not [$(shown "$@")] (line: $(grep -m1 "^$setting=" "$unit" || true))"
}
# verified WHAT UNIT: systemd-analyze verify has nothing to say about the unit (if installed)
verified() {
  [[ -n "$ANALYZE" ]] || return 0
  mkdir -p "$T/verify"
  cp "$2" "$T/verify/kumite.service"
  if "$ANALYZE" verify --man=no "$T/verify/kumite.service" >"$T/verify.out" 2>&1 \
      && ! grep -q 'kumite\.service' "$T/verify.out"; then
    pass
  else
    fail "$1: systemd-analyze verify: $(grep -m1 'kumite\.service' "$T/verify.out" || head -1 "$T/verify.out")"
  fi
}
# checkout DIR: a copy of the script and the unit template in DIR, as a checkout would have them
checkout() {
  mkdir -p "$1/scripts" "$1/config/systemd"
  cp "$SCRIPT" "$1/scripts/install-service.sh"
  cp "$ROOT/config/systemd/kumite.service.in" "$1/config/systemd/kumite.service.in"
  cp "$ROOT/config/demo.toml" "$1/config/demo.toml"
}
# fake_kumite DIR: an executable DIR/kumite
fake_kumite() { mkdir -p "$1"; printf '#!/bin/sh\nexit 0\n' >"$1/kumite"; chmod +x "$1/kumite"; }
# install WHAT CHECKOUT ARGS...: run the checkout's script with ARGS --dry-run; the unit in $T/unit
install() {
  local what=$1 dir=$2
  shift 2
  if (cd "$dir" && bash scripts/install-service.sh "$@" --dry-run) >"$T/unit" 2>"$T/err"; then
    pass; return 0
  fi
  fail "$what: the script failed: $(head -1 "$T/err")"
  return 1
}
# refused WHAT CHECKOUT OPTION ARGS...: the script exits non-zero with one line naming OPTION
refused() {
  local what=$1 dir=$2 option=$3 rc=0
  shift 3
  (cd "$dir" && bash scripts/install-service.sh "$@" --dry-run) >"$T/unit" 2>"$T/err" || rc=$?
  if [[ $rc -eq 0 ]]; then
    fail "$what: not refused (exit 0; $(grep -m1 -e '^ExecStart=' -e '^Environment=' "$T/unit" || true))"
  elif [[ $(wc -l <"$T/err") -ne 1 ]] || ! grep -qF -- "$option" "$T/err"; then
    fail "$what: refused (exit $rc) but not with one line naming $option: $(shown "$(cat "$T/err")")"
  else
    pass
  fi
}

fake_kumite "$T/bin"
KUMITE=$T/bin/kumite

# The demo's case as documented: a unit like the one the sed version wrote (plain paths need no
# quotes), byte for byte when the temporary folder's path is plain.
checkout "$T/plain"
if install "demo" "$T/plain" --config config/demo.toml --display :0 --kumite "$KUMITE"; then
  old=$(<"$ROOT/config/systemd/kumite.service.in")
  for kv in "@NAME@=kumite" "@CONFIG@=$T/plain/config/demo.toml" "@REPO@=$T/plain" "@KUMITE@=$KUMITE" \
            "@ARGS@=" "@WATCHDOG_SEC@=10" "@RESTART_SEC@=2" "@ENVIRONMENT@=Environment=DISPLAY=:0"; do
    old=${old//"${kv%%=*}"/"${kv#*=}"}
  done
  if [[ ! "$T" =~ ^[A-Za-z0-9_./-]+$ ]]; then
    echo "note: $T needs quoting in a unit: the demo's unit is not compared byte for byte"
  elif [[ "$(<"$T/unit")" == "$old" ]]; then
    pass
  else
    fail "demo: the unit differs from the plain substitution: $(diff <(printf '%s\n' "$old") "$T/unit" | head -4 | tr '\n' ' ')"
  fi
  expect "demo" "$T/unit" ExecStart "$KUMITE" --config "$T/plain/config/demo.toml"
  expect "demo" "$T/unit" WorkingDirectory "$T/plain"
  expect "demo" "$T/unit" Environment "DISPLAY=:0"
  verified "demo" "$T/unit"
fi

# Folders with one special character each, then all of them at once. The checkout, the config,
# the data folder and (where systemd can run it from there) kumite are all in the folder; the
# folder's name is in DISPLAY too.
NAMES=("my site" "a&b" "100%d" 'pay $HOME' 'say "hi"' 'back\slash' "it's" 'semi ; colon' "café"
       'all of: & %n $USER ${X} " \ '"'"' ;')
for name in "${NAMES[@]}"; do
  dir="$T/cases/$name"
  checkout "$dir"
  cp "$ROOT/config/demo.toml" "$dir/site.toml"
  if [[ "$name" == *[\"\'\\]* ]]; then
    kumite=$KUMITE   # systemd runs no executable whose path has a quote or a backslash in it
    fake_kumite "$dir/bin"
    refused "kumite in [$name]" "$dir" --kumite --config "$dir/site.toml" --display :0 --kumite "$dir/bin/kumite"
  else
    fake_kumite "$dir/bin"
    kumite=$dir/bin/kumite
  fi
  install "[$name]" "$dir" --config "$dir/site.toml" --kumite "$kumite" --data-dir "$dir/data" --display ":0 $name" || continue
  expect "[$name]" "$T/unit" ExecStart "$kumite" --config "$dir/site.toml"
  expect "[$name]" "$T/unit" WorkingDirectory "$dir"
  expect "[$name]" "$T/unit" Environment "KUMITE_DATA_DIR=$dir/data" "DISPLAY=:0 $name"
  expect "[$name]" "$T/unit" Description "Kumite CAVE installation ($dir/site.toml)"
  expect "[$name]" "$T/unit" Documentation "$dir/app/README.md"
  verified "[$name]" "$T/unit"
done

# --args: split on whitespace, each word reaching kumite as written.
if install "--args" "$T/plain" --config config/demo.toml --kumite "$KUMITE" \
     --args '--headless  --frames 5 --out /tmp/o%u$HOME --title a"b\c'"'"'d ; ${X}'; then
  expect "--args" "$T/unit" ExecStart "$KUMITE" --config "$T/plain/config/demo.toml" --headless --frames 5 \
    --out '/tmp/o%u$HOME' --title 'a"b\c'"'"'d' ';' '${X}'
  verified "--args" "$T/unit"
fi

# A newline or another control character cannot be written into a unit: refused, one line.
nl="$T/cases/new"$'\n'"line"
checkout "$nl"
cp "$ROOT/config/demo.toml" "$nl/site.toml"
fake_kumite "$nl/bin"
refused "config with a newline" "$T/plain" --config --config "$nl/site.toml" --kumite "$KUMITE" --display :0
tab="$T/cases/tab"$'\t'"stop"
mkdir -p "$tab"
cp "$ROOT/config/demo.toml" "$tab/site.toml"
refused "config with a tab" "$T/plain" --config --config "$tab/site.toml" --kumite "$KUMITE" --display :0
refused "kumite with a newline" "$T/plain" --kumite --config config/demo.toml --kumite "$nl/bin/kumite" --display :0
refused "data dir with a newline" "$T/plain" --data-dir --config config/demo.toml --kumite "$KUMITE" --display :0 --data-dir "$nl/data"
refused "display with a newline" "$T/plain" --display --config config/demo.toml --kumite "$KUMITE" --display $':0\n:1'
refused "args with a newline" "$T/plain" --args --config config/demo.toml --kumite "$KUMITE" --display :0 --args $'--no-console\n--x'
refused "checkout with a newline" "$nl" "checkout" --config config/demo.toml --kumite "$KUMITE" --display :0
# WorkingDirectory= takes the checkout's path bare: a trailing backslash would continue the line.
checkout "$T/cases/ends\\"
refused "checkout ending in a backslash" "$T/cases/ends\\" "checkout" --config config/demo.toml --kumite "$KUMITE" --display :0

echo "$PASSED passed, $FAILED failed"
[[ $FAILED -eq 0 ]] || { echo "test-install-service.sh: $FAILED check(s) failed (script: $SCRIPT)" >&2; exit 1; }
