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
REPO=$(pwd)

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
  --args "ARGS"        more kumite arguments (e.g. "--no-console")
  --dry-run            print the unit and do nothing else
  --no-start           install and enable, but do not start now
  -h, --help           this text
USAGE
}

die() { echo "install-service.sh: $*" >&2; exit 1; }

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

[[ -n "$CONFIG" ]] || die "--config FILE is required (see --help)"
[[ -f "$CONFIG" ]] || die "--config $CONFIG: no such file"
[[ "$NAME" =~ ^[A-Za-z0-9_.@-]+$ ]] || die "--name $NAME: letters, digits, _ . @ - only"
seconds_in() {  # seconds_in VALUE MIN MAX: a decimal number of seconds within [MIN, MAX]
  [[ "$1" =~ ^[0-9]+(\.[0-9]+)?$ ]] && awk "BEGIN{exit !($1 >= $2 && $1 <= $3)}"
}
if ! seconds_in "$WATCHDOG" 1 600; then die "--watchdog-sec $WATCHDOG: a number of seconds, 1..600"; fi
if ! seconds_in "$RESTART" 0 600; then die "--restart-sec $RESTART: a number of seconds, 0..600"; fi
[[ -x "$KUMITE" ]] || die "--kumite $KUMITE: not an executable (build first: scripts/setup.sh)"
CONFIG=$(realpath "$CONFIG")
KUMITE=$(realpath "$KUMITE")
if [[ -n "$DATA_DIR" ]]; then DATA_DIR=$(realpath -m "$DATA_DIR"); fi

ENV_LINES=""
[[ -n "$DATA_DIR" ]] && ENV_LINES+="Environment=KUMITE_DATA_DIR=$DATA_DIR"$'\n'
[[ -n "$DISPLAY_VAR" ]] && ENV_LINES+="Environment=DISPLAY=$DISPLAY_VAR"$'\n'
# The show draws the walls in windows on the projectors' X display. Without one, only a test
# service makes sense (headless writes frames.jsonl without end: give --frames and --out).
if [[ -z "$DISPLAY_VAR" && ! " $ARGS " =~ " --headless " ]]; then
  die "no display: give --display :0 (the projectors' X display), or for a test service --args \"--headless --frames N --out DIR\""
fi

UNIT=$(sed -e "s|@NAME@|$NAME|g" -e "s|@CONFIG@|$CONFIG|g" -e "s|@REPO@|$REPO|g" -e "s|@KUMITE@|$KUMITE|g" \
           -e "s|@ARGS@|${ARGS:+ $ARGS}|g" -e "s|@WATCHDOG_SEC@|$WATCHDOG|g" -e "s|@RESTART_SEC@|$RESTART|g" \
           config/systemd/kumite.service.in)
UNIT=${UNIT//@ENVIRONMENT@/${ENV_LINES%$'\n'}}

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
