#!/usr/bin/env bash
# A 64-byte TPDO (CANopen FD) decoded by `canopen monitor` on vcan0 with MTU 72:
# `canopen --fd simulate` runs the CANopen FD test device (tests/vcan/fd-device.eds, TPDO1 maps
# 64 bytes) in one process; another starts it (`nmt start`) and writes 0xDEADBEEF into
# 0x2100:05, one of the mapped objects, by USDO; `canopen --fd --eds N=FILE --json monitor`
# shows TPDO1 decoded with that value at its name, and `candump -L` on the side shows the
# TPDO as a 64-byte CAN FD frame (`##`) on 0x180 + N. The MTU is set back as it was. Runs
# inside the rig (tests/vcan/run-all):
#   fd_tpdo_cli.sh PATH/TO/canopen
# CANOPEN_VCAN_IFACE=udp:GROUP:PORT runs the same steps on the UDP bus, without candump.
set -euo pipefail
canopen=$1
iface=${CANOPEN_VCAN_IFACE:-vcan0}
eds=tests/vcan/fd-device.eds
node=13
tmp=$(mktemp -d /tmp/fd-tpdo.XXXXXX)
socketcan=1
case $iface in udp:*) socketcan=0 ;; esac

mtu=
[ $socketcan = 1 ] && mtu=$(cat "/sys/class/net/$iface/mtu")
pids=()
set_mtu() {
    ip link set "$iface" down
    ip link set "$iface" mtu "$1"
    ip link set "$iface" up
}
cleanup() {
    for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
    if [ $socketcan = 1 ] && [ "$(cat "/sys/class/net/$iface/mtu")" != "$mtu" ]; then
        set_mtu "$mtu"
        echo "MTU of $iface set back to $mtu"
    fi
}
trap cleanup EXIT
[ $socketcan = 0 ] || [ "$mtu" = 72 ] || set_mtu 72

if [ $socketcan = 1 ]; then
    candump -L "$iface" >"$tmp/candump.log" &
    cd_pid=$!
    pids+=($cd_pid)
fi
"$canopen" --iface "$iface" --fd simulate "$eds" --node-id $node --duration 60 \
    >/dev/null 2>"$tmp/sim.err" &
sim=$!
pids+=($sim)
for _ in $(seq 150); do
    "$canopen" --iface "$iface" --fd usdo read $node 0x1000 --type u32 >/dev/null 2>&1 && break
    sleep 0.2
done
name=$("$canopen" --iface "$iface" --fd usdo read $node 0x1008)
[ "$name" = "canopen-rs FD test device" ] || { echo "0x1008: $name"; exit 1; }
echo "ok: the CANopen FD test device answers USDO as node $node"

"$canopen" --iface "$iface" --fd --eds "$node=$eds" --json monitor --duration 5 \
    >"$tmp/monitor.json" 2>"$tmp/monitor.err" &
mon=$!
pids+=($mon)
# Listening once it shows the device's heartbeat (every 100 ms).
for _ in $(seq 100); do
    [ -s "$tmp/monitor.json" ] && break
    sleep 0.05
done
[ -s "$tmp/monitor.json" ] || { echo "the monitor showed nothing"; cat "$tmp/monitor.err"; exit 1; }

"$canopen" --iface "$iface" --fd nmt start $node
"$canopen" --iface "$iface" --fd --eds "$node=$eds" usdo write $node 0x2100 5 0xDEADBEEF
back=$("$canopen" --iface "$iface" --fd --eds "$node=$eds" usdo read $node 0x2100 5)
[ "$back" = 3735928559 ] || { echo "0x2100:05 read back: $back"; exit 1; }
echo "ok: node $node started, 0x2100:05 (mapped into TPDO1) written by USDO: $back"

wait "$mon"
python3 - "$tmp/monitor.json" $node <<'PY'
import json, sys
path, node = sys.argv[1], int(sys.argv[2])
lines = [json.loads(l) for l in open(path) if l.strip()]
cob = "%03X##" % (0x180 + node)
tpdos = [l for l in lines if l.get("pdo") == "TPDO1 node %d" % node]
assert tpdos, "no TPDO1 decoded in %d lines" % len(lines)
assert all(l["frame"].startswith(cob) for l in tpdos), tpdos[0]["frame"]
hit = [l for l in tpdos if len(l["values"]) == 17 and l["values"][4]["value"] == 0xDEADBEEF]
assert hit, [l["decoded"] for l in tpdos]
t = hit[0]
v5 = t["values"][4]
assert (v5["index"], v5["sub"], v5["name"]) == (0x2100, 5, "Measured values / Value 5"), v5
assert len(t["frame"].split("##")[1]) == 1 + 2 * 64, t["frame"]
assert [v["name"] for v in t["values"][14:]] == ["Temperature", "Status word", "Offset"], t
assert [v["value"] for v in t["values"][14:]] == [21.5, 1, -5], t
print("ok: monitor --json decodes the 64-byte TPDO1:", t["frame"][:24] + "...")
print("   ", v5["name"], "=", v5["value"], "|", t["decoded"][:90] + "...")
PY

kill "$sim"
wait "$sim" 2>/dev/null || true
if [ $socketcan = 1 ]; then
    sleep 0.5
    kill "$cd_pid"
    wait "$cd_pid" 2>/dev/null || true
    python3 - "$tmp/candump.log" $node <<'PY'
import sys
path, node = sys.argv[1], int(sys.argv[2])
frames = [l.split()[2] for l in open(path) if l.strip()]
prefix = "%03X##" % (0x180 + node)
tpdo = [f for f in frames if f.startswith(prefix)]
full = [f for f in tpdo if len(f.split("##")[1]) == 1 + 128]
assert full, "no 64-byte CAN FD frame on %s in %d frames" % (prefix, len(frames))
written = [f for f in full if f.split("##")[1][1:][32:40] == "EFBEADDE"]
assert written, full
print("ok: candump -L shows", len(tpdo), "TPDO1 frames as CAN FD,", len(full),
      "of 64 bytes; with the written value:", written[0])
PY
fi
rm -rf "$tmp"
