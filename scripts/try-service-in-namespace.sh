#!/usr/bin/env bash
# Runs kumite's systemd unit under a real systemd on a machine that has systemd installed but
# not running as PID 1 (a development container): systemd in system mode as PID 1 of private
# pid/mount/uts/ipc/net namespaces, the unit made by scripts/install-service.sh --dry-run, and
# the watchdog chain played out: READY=1, the frame loop hung on purpose
# (--debug-hang-after-frames), the watchdog's SIGABRT, the restart, READY=1 again; then a
# kill -9 (restarted) and a stop (SIGTERM, a clean exit). Prints the journal's lines for it.
#
#   sudo scripts/try-service-in-namespace.sh [--hang-after-frames 300] [--work DIR (build/service-test)]
#
# Needs root (namespaces, mounts). A test aid for developers, never part of an installation.
#
# CONTAINMENT (learned the hard way): a systemd booting normally runs systemd-tmpfiles
# --remove --boot, which empties the host's /tmp, and sysinit services that change the kernel
# (sysctl, udev). Here /run, /tmp, /var/tmp and the journal are private tmpfs mounts, every
# *.wants / *.requires folder of the unit paths is covered by an empty tmpfs (nothing but
# journald and kumite starts), systemd-remount-fs is masked, and the namespace is ended with
# SIGKILL to its PID 1, never `poweroff` (systemd-shutdown remounts every file system
# read-only, the host's included).
set -euo pipefail
cd "$(dirname "$0")/.."
REPO=$(pwd)
HANG=300 WORK=build/service-test
while [[ $# -gt 0 ]]; do
  case "$1" in
    --hang-after-frames) HANG=${2:?frames}; shift 2 ;;
    --work) WORK=${2:?folder}; shift 2 ;;
    -h|--help) sed -n 2,21p "$0"; exit 0 ;;
    *) echo "try-service-in-namespace.sh: unknown argument \"$1\" (see --help)" >&2; exit 1 ;;
  esac
done
[[ $(id -u) == 0 ]] || { echo "try-service-in-namespace.sh: needs root (namespaces and mounts)" >&2; exit 1; }
[[ -x /lib/systemd/systemd ]] || { echo "try-service-in-namespace.sh: /lib/systemd/systemd not installed" >&2; exit 1; }
[[ -x build/bin/kumite ]] || { echo "try-service-in-namespace.sh: build/bin/kumite missing (scripts/setup.sh)" >&2; exit 1; }
[[ "$HANG" =~ ^[0-9]+$ ]] || { echo "try-service-in-namespace.sh: --hang-after-frames $HANG: a whole number" >&2; exit 1; }
mkdir -p "$WORK/units" "$WORK/bin"
WORK=$(realpath "$WORK")
# The namespace covers /run, /tmp and /var/tmp with empty tmpfs mounts: WORK must lie elsewhere.
[[ "$WORK" =~ ^/(run|tmp|var/tmp)(/|$) ]] && { echo "try-service-in-namespace.sh: --work $WORK: not under /run, /tmp or /var/tmp" >&2; exit 1; }
cp build/bin/kumite "$WORK/bin/kumite"   # a rebuild during the test does not change the service
rm -rf "$WORK/out"
scripts/install-service.sh --dry-run --config config/demo.toml --kumite "$WORK/bin/kumite" --data-dir build/demo \
  --args "--headless --frames 1000000 --out $WORK/out --save-every 0 --health-file $WORK/health.json --debug-hang-after-frames $HANG" \
  >"$WORK/units/kumite.service"
printf '[Unit]\nDescription=kumite service test (journald only)\nWants=systemd-journald.service\n' \
  >"$WORK/units/kumite-test.target"
cat >"$WORK/boot.sh" <<EOF
#!/bin/bash
set -e
mount --make-rprivate /
mount -t proc proc /proc
for d in /run /tmp /var/tmp; do mount -t tmpfs tmpfs \$d; done
[ -d /var/log/journal ] && mount -t tmpfs tmpfs /var/log/journal
for d in \$(find /usr/lib/systemd/system /etc/systemd/system /usr/lib/systemd/user /etc/systemd/user -maxdepth 1 -type d \\( -name '*.wants' -o -name '*.requires' \\) 2>/dev/null); do
  mount -t tmpfs -o ro tmpfs "\$d"
done
mkdir -p /run/systemd/system
cp "$WORK"/units/* /run/systemd/system/
ln -s /dev/null /run/systemd/system/systemd-remount-fs.service
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
end_namespace() { kill -9 "$PID1" 2>/dev/null || true; wait "$UNSHARE" 2>/dev/null || true; }
trap end_namespace EXIT
in_ns() { nsenter -t "$PID1" -a "$@"; }
for _ in $(seq 50); do
  [[ $(in_ns systemctl is-system-running 2>/dev/null || true) =~ running|degraded ]] && break
  sleep 0.2
done
echo "systemd $(in_ns systemctl --version | head -1 | cut -d' ' -f2) as PID 1 of a private namespace (host pid $PID1)"
echo "== start (blocks until READY=1)"
in_ns systemctl start kumite.service
echo "== waiting for the hang after $HANG frames, the watchdog and the restart"
for _ in $(seq 600); do
  in_ns journalctl -o cat 2>/dev/null | grep -q 'restart counter is at 1' && break
  sleep 1
done
for _ in $(seq 180); do
  [[ $(in_ns journalctl -o cat 2>/dev/null | grep -c 'READY=1 sent') -ge 2 ]] && break
  sleep 1
done
echo "== kill -9 (Restart=on-failure starts it again)"
in_ns systemctl kill -s KILL kumite.service
for _ in $(seq 180); do
  [[ $(in_ns journalctl -o cat 2>/dev/null | grep -c 'READY=1 sent') -ge 3 ]] && break
  sleep 1
done
echo "== stop (SIGTERM: a clean exit, not restarted)"
in_ns systemctl stop kumite.service
in_ns journalctl --no-pager -o short-precise |
  grep -E 'systemd\[1\]: (Started |Stopped )?kumite|READY=1 sent|hangs now|stopped by SIG|Watchdog' || true
