#!/usr/bin/env bash
# Runs kumite's systemd unit under a real systemd on a machine that has systemd installed but
# not running as PID 1 (a development container): systemd as PID 1 of private
# pid/mount/uts/ipc/net namespaces, and the watchdog chain played out: READY=1, the frame loop
# hung on purpose (--debug-hang-after-frames), the watchdog's SIGABRT, the restart, READY=1
# again. Prints the journal's lines for it.
#   --mode user (default): as shipped: D-Bus, logind, root's user manager (user@0), then
#     scripts/install-service.sh as written (systemctl --user: install, enable, start); after
#     the watchdog's restart, a boot with lingering (`loginctl enable-linger`, logind started
#     again: it starts the user manager, which starts kumite); then `systemctl --user stop`.
#   --mode system: the same unit as a system service (install-service.sh --dry-run), plus a
#     kill -9 (restarted) and a stop.
#
#   sudo scripts/try-service-in-namespace.sh [--mode user|system] [--hang-after-frames 300]
#                                            [--work DIR (build/service-test)]
#
# Needs root (namespaces, mounts). A test aid for developers, never part of an installation.
#
# CONTAINMENT (learned the hard way): a systemd booting normally runs systemd-tmpfiles
# --remove --boot, which empties the host's /tmp, and sysinit services that change the kernel
# (sysctl, udev), and logind writes its linger files to /var/lib/systemd (it sees the mounts
# made before it starts, not later ones). Here /run, /tmp, /var/tmp, the journal,
# /var/lib/systemd and ~/.config/systemd are private tmpfs mounts made before systemd, every
# *.wants / *.requires folder of the unit paths is covered by an empty tmpfs (nothing but
# journald, D-Bus, logind and kumite start), systemd-remount-fs and modprobe@drm are masked,
# and the namespace is ended with
# SIGKILL to its PID 1, never `poweroff` (systemd-shutdown remounts every file system
# read-only, the host's included).
set -euo pipefail
cd "$(dirname "$0")/.."
REPO=$(pwd)
HANG=300 WORK=build/service-test MODE=user
while [[ $# -gt 0 ]]; do
  case "$1" in
    --hang-after-frames) HANG=${2:?frames}; shift 2 ;;
    --work) WORK=${2:?folder}; shift 2 ;;
    --mode) MODE=${2:?user or system}; shift 2 ;;
    -h|--help) sed -n 2,30p "$0"; exit 0 ;;
    *) echo "try-service-in-namespace.sh: unknown argument \"$1\" (see --help)" >&2; exit 1 ;;
  esac
done
[[ $(id -u) == 0 ]] || { echo "try-service-in-namespace.sh: needs root (namespaces and mounts)" >&2; exit 1; }
[[ -x /lib/systemd/systemd ]] || { echo "try-service-in-namespace.sh: /lib/systemd/systemd not installed" >&2; exit 1; }
[[ -x build/bin/kumite ]] || { echo "try-service-in-namespace.sh: build/bin/kumite missing (scripts/setup.sh)" >&2; exit 1; }
[[ "$MODE" == user || "$MODE" == system ]] || { echo "try-service-in-namespace.sh: --mode $MODE: user or system" >&2; exit 1; }
[[ "$HANG" =~ ^[0-9]+$ ]] || { echo "try-service-in-namespace.sh: --hang-after-frames $HANG: a whole number" >&2; exit 1; }
mkdir -p "$WORK/units" "$WORK/bin"
WORK=$(realpath "$WORK")
# The namespace covers /run, /tmp and /var/tmp with empty tmpfs mounts: WORK must lie elsewhere.
[[ "$WORK" =~ ^/(run|tmp|var/tmp)(/|$) ]] && { echo "try-service-in-namespace.sh: --work $WORK: not under /run, /tmp or /var/tmp" >&2; exit 1; }
cp build/bin/kumite "$WORK/bin/kumite"   # a rebuild during the test does not change the service
rm -rf "$WORK/out"
# ~/.config/systemd is covered by a tmpfs in the namespace: it must exist to be mounted on.
MADE_CONFIG=0
[[ -d "$HOME/.config/systemd" ]] || { mkdir -p "$HOME/.config/systemd"; MADE_CONFIG=1; }
KARGS="--headless --frames 1000000 --out $WORK/out --save-every 0 --health-file $WORK/health.json --debug-hang-after-frames $HANG"
scripts/install-service.sh --dry-run --config config/demo.toml --kumite "$WORK/bin/kumite" --data-dir build/demo \
  --args "$KARGS" >"$WORK/units/kumite.service"
printf '[Unit]\nDescription=kumite service test (journald only)\nWants=systemd-journald.service\n' \
  >"$WORK/units/kumite-test.target"
cat >"$WORK/boot.sh" <<EOF
#!/bin/bash
set -e
mount --make-rprivate /
mount -t proc proc /proc
for d in /run /tmp /var/tmp; do mount -t tmpfs tmpfs \$d; done
[ -d /var/log/journal ] && mount -t tmpfs tmpfs /var/log/journal
mount -t tmpfs tmpfs /var/lib/systemd
mount -t tmpfs tmpfs "$HOME/.config/systemd"
for d in \$(find /usr/lib/systemd/system /etc/systemd/system /usr/lib/systemd/user /etc/systemd/user -maxdepth 1 -type d \\( -name '*.wants' -o -name '*.requires' \\) 2>/dev/null); do
  mount -t tmpfs -o ro tmpfs "\$d"
done
mkdir -p /run/systemd/system
cp "$WORK"/units/* /run/systemd/system/
ln -s /dev/null /run/systemd/system/systemd-remount-fs.service
ln -s /dev/null /run/systemd/system/modprobe@drm.service
exec /lib/systemd/systemd --unit=kumite-test.target --log-target=journal-or-kmsg --show-status=no
EOF
chmod +x "$WORK/boot.sh"
unshare --pid --mount --uts --ipc --net --fork --propagation private "$WORK/boot.sh" >"$WORK/boot.log" 2>&1 &
UNSHARE=$!
PID1=""
for _ in $(seq 50); do
  PID1=$(pgrep -P "$UNSHARE" -f 'systemd --unit=kumite-test.target' || true)
  [[ -n "$PID1" ]] && break
  sleep 0.2
done
[[ -n "$PID1" ]] || { echo "try-service-in-namespace.sh: systemd did not start (see $WORK/boot.log)" >&2; exit 1; }
end_namespace() {
  kill -9 "$PID1" 2>/dev/null || true
  wait "$UNSHARE" 2>/dev/null || true
  [[ $MADE_CONFIG == 1 ]] && rmdir "$HOME/.config/systemd" 2>/dev/null || true
}
trap end_namespace EXIT
in_ns() { nsenter -t "$PID1" -a "$@"; }
for _ in $(seq 50); do
  [[ $(in_ns systemctl is-system-running 2>/dev/null || true) =~ running|degraded ]] && break
  sleep 0.2
done
echo "systemd $(in_ns systemctl --version | head -1 | cut -d' ' -f2) as PID 1 of a private namespace (host pid $PID1)"
ready_count() { in_ns journalctl -o cat 2>/dev/null | grep -c 'READY=1 sent' || true; }
wait_ready() {  # wait_ready N: until the journal holds N READY=1 lines (at most 3 minutes)
  for _ in $(seq 180); do [[ $(ready_count) -ge $1 ]] && return 0; sleep 1; done
  echo "try-service-in-namespace.sh: no READY=1 number $1 in 3 minutes" >&2
}
wait_restart() {
  for _ in $(seq 600); do in_ns journalctl -o cat 2>/dev/null | grep -q 'restart counter is at 1' && return 0; sleep 1; done
}
if [[ $MODE == system ]]; then
  echo "== start (blocks until READY=1)"
  in_ns systemctl start kumite.service
  echo "== waiting for the hang after $HANG frames, the watchdog and the restart"
  wait_restart
  wait_ready 2
  echo "== kill -9 (Restart=on-failure starts it again)"
  in_ns systemctl kill -s KILL kumite.service
  wait_ready 3
  echo "== stop (SIGTERM: a clean exit, not restarted)"
  in_ns systemctl stop kumite.service
else
  in_ns rm -f /run/systemd/system/kumite.service
  in_ns systemctl daemon-reload
  in_ns systemctl start dbus.service systemd-logind.service
  echo "== loginctl enable-linger root (starts root's user manager)"
  in_ns loginctl enable-linger root
  for _ in $(seq 50); do in_ns systemctl is-active -q user@0.service && break; sleep 0.2; done
  echo "== scripts/install-service.sh as written (systemctl --user)"
  in_ns env XDG_RUNTIME_DIR=/run/user/0 bash -c "cd '$REPO' && scripts/install-service.sh --config config/demo.toml --kumite '$WORK/bin/kumite' --data-dir build/demo --args '$KARGS'"
  wait_ready 1
  echo "== waiting for the hang after $HANG frames, the watchdog and the restart"
  wait_restart
  wait_ready 2
  echo "== a boot with lingering: the user manager stopped, logind started again"
  in_ns systemctl stop user@0.service
  in_ns systemctl restart systemd-logind.service
  wait_ready 3
  echo "== systemctl --user stop (SIGTERM: a clean exit, not restarted)"
  in_ns env XDG_RUNTIME_DIR=/run/user/0 systemctl --user stop kumite.service
fi
in_ns journalctl --no-pager -o short-precise |
  grep -E 'systemd\[[0-9]+\]: (Started |Stopped |Starting )?(kumite|user@0)|READY=1 sent|hangs now|stopped by SIG|Watchdog' || true
