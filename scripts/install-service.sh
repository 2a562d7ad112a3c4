#!/usr/bin/env bash
# Installs kumite as a systemd user service for one installation config and enables it.
#
#   scripts/install-service.sh --config config/demo.toml            # install, enable, (re)start
#   scripts/install-service.sh --config site.toml --dry-run          # print the unit only
#   scripts/install-service.sh --help
#
# The unit (config/systemd/kumite.service.in) runs `kumite --config FILE` with Type=notify and a
# watchdog: kumite says READY=1 when the show is up and pings WATCHDOG=1 from its frame loop, so
# systemd restarts a hung show. Logs: journalctl --user -u NAME. Status: kumite status --config FILE.
set -euo pipefail
cd "$(dirname "$0")/.."
REPO=$PWD

usage() {
  cat <<USAGE
usage: scripts/install-service.sh --config FILE [options]

Installs ~/.config/systemd/user/NAME.service running kumite on FILE, enables it (started with
the user's session; at boot too after 'loginctl enable-linger \$USER') and (re)starts it.

  --config FILE        installation file (TOML), required; made absolute
  --name NAME          unit name (default: kumite)
  --kumite PATH        the kumite binary (default: build/bin/kumite of this checkout)
  --data-dir DIR       KUMITE_DATA_DIR for the service (default: none, the config's data_dir)
  --display DISPLAY    DISPLAY for the walls' windows (default: \$DISPLAY now; required without
                       --args "--headless ...")
  --watchdog-sec S     watchdog timeout, s (default: 10)
  --restart-sec S      pause before a restart, s (default: 2)
  --args "ARGS"        more kumite arguments (e.g. "--no-console"), split on whitespace; each
                       word is passed as written (no quoting, no \$VAR, no % specifiers)
  --dry-run            print the unit and do nothing else
  --no-start           install and enable, but do not start now
  -h, --help           this text
USAGE
}

die() { echo "install-service.sh: $*" >&2; exit 1; }
# bash 5.2 reads '&' in the replacement of ${VAR//PATTERN/REPLACEMENT} as the matched text.
shopt -u patsub_replacement 2>/dev/null || true

CONFIG="" NAME=kumite KUMITE="$REPO/build/bin/kumite" DATA_DIR="" DISPLAY_VAR="${DISPLAY:-}"
WATCHDOG=10 RESTART=2 ARGS="" DRY=0 START=1
while [[ $# -gt 0 ]]; do
  case "$1" in
    --config) CONFIG=${2:?--config needs a file}; shift 2 ;;
    --name) NAME=${2:?--name needs a name}; shift 2 ;;
    --kumite) KUMITE=${2:?--kumite needs a path}; shift 2 ;;
    --data-dir) DATA_DIR=${2:?--data-dir needs a folder}; shift 2 ;;
    --display) DISPLAY_VAR=${2?--display needs a value}; shift 2 ;;
    --watchdog-sec) WATCHDOG=${2:?--watchdog-sec needs seconds}; shift 2 ;;
    --restart-sec) RESTART=${2:?--restart-sec needs seconds}; shift 2 ;;
    --args) ARGS=${2?--args needs a value}; shift 2 ;;
    --dry-run) DRY=1; shift ;;
    --no-start) START=0; shift ;;
    -h|--help) usage; exit 0 ;;
    *) die "unknown argument \"$1\" (see --help)" ;;
  esac
done

# Every value goes into the unit file, one setting a line: a newline (or any other control
# character) in one cannot be written there, so it is refused before anything else.
refuse_controls() {  # refuse_controls WHAT VALUE
  local LC_ALL=C
  if [[ "$2" == *[[:cntrl:]]* ]]; then
    die "$1 $(printf %q "$2"): a newline or other control character cannot be written into a systemd unit"
  fi
}
# realpath, keeping a trailing newline that $(...) would drop (refused just after).
resolve() {  # resolve [realpath options] PATH -> REPLY
  local r
  r=$(realpath "${@:1:$#-1}" -- "${!#}" && echo .) || return 1
  REPLY=${r%$'\n.'}
}
refuse_controls "this checkout's path" "$REPO"
refuse_controls --config "$CONFIG"
refuse_controls --kumite "$KUMITE"
refuse_controls --data-dir "$DATA_DIR"
refuse_controls --display "$DISPLAY_VAR"
refuse_controls --args "${ARGS//$'\t'/ }"   # tabs separate words like spaces

[[ -n "$CONFIG" ]] || die "--config FILE is required (see --help)"
[[ -f "$CONFIG" ]] || die "--config $CONFIG: no such file"
[[ "$NAME" =~ ^[A-Za-z0-9_.@-]+$ ]] || die "--name $NAME: letters, digits, _ . @ - only"
seconds_in() {  # seconds_in VALUE MIN MAX: a decimal number of seconds within [MIN, MAX]
  [[ "$1" =~ ^[0-9]+(\.[0-9]+)?$ ]] && awk "BEGIN{exit !($1 >= $2 && $1 <= $3)}"
}
if ! seconds_in "$WATCHDOG" 1 600; then die "--watchdog-sec $WATCHDOG: a number of seconds, 1..600"; fi
if ! seconds_in "$RESTART" 0 600; then die "--restart-sec $RESTART: a number of seconds, 0..600"; fi
[[ -x "$KUMITE" ]] || die "--kumite $KUMITE: not an executable (build first: scripts/setup.sh)"
resolve "$CONFIG"; CONFIG=$REPLY
resolve "$KUMITE"; KUMITE=$REPLY
if [[ -n "$DATA_DIR" ]]; then resolve -m "$DATA_DIR"; DATA_DIR=$REPLY; fi
refuse_controls --config "$CONFIG"   # again: a symbolic link may lead to such a name
refuse_controls --kumite "$KUMITE"
refuse_controls --data-dir "$DATA_DIR"
# systemd refuses an executable whose path has a quote or a backslash in it ("Executable name
# contains special characters"), however it is quoted.
if [[ "$KUMITE" == *[\"\'\\]* ]]; then
  die "--kumite $KUMITE: systemd does not run an executable whose path has a quote (' or \") or a backslash in it"
fi
# WorkingDirectory= takes the path bare: a trailing space would be stripped and a trailing
# backslash would join the next line to it.
if [[ "$REPO" == *[[:space:]\\] ]]; then
  die "this checkout's path $REPO ends in a space or a backslash: WorkingDirectory= cannot carry it"
fi

# The show draws the walls in windows on the projectors' X display. Without one, only a test
# service makes sense (headless writes frames.jsonl without end: give --frames and --out).
if [[ -z "$DISPLAY_VAR" && ! " $ARGS " =~ " --headless " ]]; then
  die "no display: give --display :0 (the projectors' X display), or for a test service --args \"--headless --frames N --out DIR\""
fi

# Writing values the way systemd reads them back (systemd.syntax(7), systemd.service(5)): in
# every setting used here '%' starts a specifier (written %%); ExecStart= splits its words on
# whitespace and unquotes "..." with C escapes (\" and \\), and expands $VAR in the arguments
# (written $$, but not in the executable's path); Environment= unquotes "KEY=value" the same
# way but expands no variables. A word of only these characters needs none of it:
PLAIN_WORD='^[A-Za-z0-9_./:,+=@-]+$'
exec_word() {  # exec_word VALUE [exe] -> REPLY: one ExecStart= word giving back VALUE
  local v=$1
  if [[ "$v" =~ $PLAIN_WORD ]]; then REPLY=$v; return; fi
  v=${v//\\/\\\\}; v=${v//\"/\\\"}; v=${v//%/%%}
  [[ ${2:-} == exe ]] || v=${v//\$/\$\$}
  REPLY="\"$v\""
}
env_word() {  # env_word KEY VALUE -> REPLY: one Environment= word setting KEY to VALUE
  local v="$1=$2"
  if [[ "$v" =~ $PLAIN_WORD ]]; then REPLY=$v; return; fi
  v=${v//\\/\\\\}; v=${v//\"/\\\"}; v=${v//%/%%}
  REPLY="\"$v\""
}
file_url_path() {  # file_url_path PATH -> REPLY: PATH percent-encoded for a file:// URL, as %%XX
  local LC_ALL=C v=$1 c i hex
  REPLY=""
  for ((i = 0; i < ${#v}; i++)); do
    c=${v:i:1}
    if [[ "$c" == [A-Za-z0-9._~/-] ]]; then REPLY+=$c; else printf -v hex '%%%%%02X' "'$c"; REPLY+=$hex; fi
  done
}

# --args: more kumite arguments, split on whitespace; each word reaches kumite as written
# (quotes, backslashes, '%' and '$' in it are escaped, not read by systemd).
read -r -a ARG_WORDS <<<"$ARGS"
ARGS_EXEC=""
for word in ${ARG_WORDS[@]+"${ARG_WORDS[@]}"}; do exec_word "$word"; ARGS_EXEC+=" $REPLY"; done

ENV_LINES=()
if [[ -n "$DATA_DIR" ]]; then env_word KUMITE_DATA_DIR "$DATA_DIR"; ENV_LINES+=("Environment=$REPLY"); fi
if [[ -n "$DISPLAY_VAR" ]]; then env_word DISPLAY "$DISPLAY_VAR"; ENV_LINES+=("Environment=$REPLY"); fi
ENVIRONMENT=$(IFS=$'\n'; printf '%s' "${ENV_LINES[*]-}")

value_for() {  # value_for KEY SETTING -> REPLY: @KEY@'s value written for the setting it is in
  local v
  case "$1" in
    NAME) REPLY=$NAME ;;
    WATCHDOG_SEC) REPLY=$WATCHDOG ;;
    RESTART_SEC) REPLY=$RESTART ;;
    ARGS) REPLY=$ARGS_EXEC ;;
    ENVIRONMENT) REPLY=$ENVIRONMENT ;;
    CONFIG|REPO|KUMITE)
      v=${!1}
      case "$2" in
        ExecStart) if [[ $1 == KUMITE ]]; then exec_word "$v" exe; else exec_word "$v"; fi ;;
        Documentation) file_url_path "$v" ;;
        '#') REPLY=$v ;;
        *) REPLY=${v//%/%%} ;;   # Description=, WorkingDirectory=: the text as it is, but '%'
      esac ;;
    *) return 1 ;;
  esac
}
fill_line() {  # fill_line LINE -> REPLY: the template's line with its @KEY@s filled in, in one pass
  local rest=$1 out="" setting=${1%%=*} token
  [[ "$1" == [\#\;]* ]] && setting='#'
  while [[ "$rest" =~ @([A-Z_]+)@ ]]; do
    token=${BASH_REMATCH[0]}
    out+=${rest%%"$token"*}
    rest=${rest#*"$token"}
    if value_for "${BASH_REMATCH[1]}" "$setting"; then out+=$REPLY; else out+=${token%@}; rest="@$rest"; fi
  done
  REPLY=$out$rest
}
UNIT=""
while IFS= read -r line || [[ -n "$line" ]]; do
  fill_line "$line"
  UNIT+=$REPLY$'\n'
done <config/systemd/kumite.service.in
UNIT=${UNIT%$'\n'}

if [[ $DRY == 1 ]]; then
  printf '%s\n' "$UNIT"
  exit 0
fi
command -v systemctl >/dev/null || die "systemctl not found: this machine has no systemd (--dry-run prints the unit)"
DIR="${XDG_CONFIG_HOME:-$HOME/.config}/systemd/user"
mkdir -p "$DIR"
TMP=$(mktemp "$DIR/.$NAME.service.XXXXXX")
printf '%s\n' "$UNIT" >"$TMP"
mv "$TMP" "$DIR/$NAME.service"
echo "installed $DIR/$NAME.service"
systemctl --user daemon-reload
systemctl --user enable "$NAME.service"
if [[ $START == 1 ]]; then systemctl --user restart "$NAME.service"; fi
echo "started at the user's login; at boot too after: loginctl enable-linger ${USER:-$(id -un)}"
echo "logs: journalctl --user -u $NAME -f    status: $KUMITE status --config $CONFIG"
