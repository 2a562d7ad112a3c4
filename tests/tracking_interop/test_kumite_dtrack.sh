#!/usr/bin/env bash
# kumite-dtrack end to end over 127.0.0.1: `send --from poses.csv` (DTrack ASCII, z-up room) ->
# `bridge` (DTrack in -> OSC out) -> `listen --osc` prints the visitor's head and hands back in
# Kumite's room; a bad packet sent to the bridge is one BAD line, the rest goes on.
# Usage: test_kumite_dtrack.sh KUMITE_DTRACK POSES_CSV
set -u
tool=$1 poses=$2
dir=$(mktemp -d)
lpid= bpid=
trap 'kill $lpid $bpid 2>/dev/null; rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*"; echo "--- listen:"; cat "$dir/listen.txt"; echo "--- bridge:"; cat "$dir/bridge.txt"; exit 1; }
port_of() {  # the port a tool prints in its first line ("... udp 0.0.0.0:PORT ...")
  for _ in $(seq 100); do
    p=$(sed -n '1s/.*udp [0-9.]*:\([0-9]*\).*/\1/p' "$1")
    [ -n "$p" ] && { echo "$p"; return; }
    sleep 0.05
  done
}
cat > "$dir/room.toml" <<TOML
[dtrack.bodies]
head = 0
left_hand = 1
right_hand = 2
TOML
"$tool" listen --osc --port 0 --config "$dir/room.toml" --duration 4 > "$dir/listen.txt" 2>&1 & lpid=$!
osc_port=$(port_of "$dir/listen.txt"); [ -n "$osc_port" ] || fail "listen printed no port"
"$tool" bridge --config "$dir/room.toml" --port 0 --osc-port "$osc_port" --duration 3 > "$dir/bridge.txt" 2>&1 & bpid=$!
dtrack_port=$(port_of "$dir/bridge.txt"); [ -n "$dtrack_port" ] || fail "bridge printed no port"
"$tool" send --config "$dir/room.toml" --port "$dtrack_port" --from "$poses" --duration 0.5 || fail "send failed"
# (bash's printf may write a line per datagram: the line number is not checked)
printf 'fr 9\n6d 1 [0 nan][1 2 3][1 0 0 0 1 0 0 0 1]\n' > "/dev/udp/127.0.0.1/$dtrack_port"
wait $bpid; wait $lpid
grep -q "^fr [0-9]* .*: head (.*) m q 1.00; left_hand (.*) m q 1.00; right_hand (.*) m q 1.00" "$dir/listen.txt" \
  || fail "no frame with head and hands"
grep -q "BAD dtrack 127.0.0.1:[0-9]*: packet:[12]: 6d\[0\]: must be a finite number, found 'nan'" "$dir/bridge.txt" \
  || fail "the nan packet was not said"
grep -q "body 3 is not configured in \[dtrack.bodies\] (ignored; said once)" "$dir/bridge.txt" || fail "feet not said"
grep -q "^packets [1-9][0-9]*, frames [1-9][0-9]*, bad 0 " "$dir/listen.txt" || fail "listen's summary"
echo "ok: $(grep -c '^fr ' "$dir/listen.txt") frames through DTrack -> OSC"
