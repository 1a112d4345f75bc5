#!/usr/bin/env bash
# USDO (CANopen FD) on vcan0 with MTU 72: `canopen --fd simulate` runs a CANopen FD device in
# one process, `canopen --fd usdo read|write` reads and writes it from others: expedited
# (0x1008, 0x1000), segmented (a 4096-byte VISIBLE_STRING written and read back, and read by
# classic SDO too), an abort with its CiA 301 code. `candump -L` on the side shows the USDO
# traffic as CAN FD frames (`##`) on 0x67F (the master, node-ID 127) and 0x58C (the device),
# full 64-byte segments among them. Then on the interface set to MTU 16 (classic only),
# `usdo read` fails with `FD not supported on vcan0 (MTU 16: ...)`. Runs inside the rig
# (tests/vcan/run-all):
#   usdo_fd_cli.sh PATH/TO/canopen
set -euo pipefail
canopen=$1
iface=${CANOPEN_VCAN_IFACE:-vcan0}
eds=tests/vcan/test-device.eds
node=12

mtu=$(cat "/sys/class/net/$iface/mtu")
pids=()
set_mtu() {
    ip link set "$iface" down
    ip link set "$iface" mtu "$1"
    ip link set "$iface" up
}
cleanup() {
    for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
    if [ "$(cat "/sys/class/net/$iface/mtu")" != "$mtu" ]; then
        set_mtu "$mtu"
        echo "MTU of $iface set back to $mtu"
    fi
}
trap cleanup EXIT
[ "$mtu" = 72 ] || set_mtu 72

candump -L "$iface" >/tmp/usdo-candump.log &
cd_pid=$!
pids+=($cd_pid)
"$canopen" --iface "$iface" --fd simulate "$eds" --node-id $node --duration 240 \
    >/dev/null 2>/tmp/usdo-sim.err &
sim=$!
pids+=($sim)
for _ in $(seq 150); do
    "$canopen" --iface "$iface" --fd usdo read $node 0x1000 --type u32 >/dev/null 2>&1 && break
    sleep 0.2
done

name=$("$canopen" --iface "$iface" --fd usdo read $node 0x1008)
[ "$name" = "canopen-rs vcan test device" ] || { echo "0x1008: $name"; exit 1; }
echo "ok: expedited USDO read of 0x1008: $name"

text=$(python3 -c 'print("".join(chr(65 + i % 26) for i in range(4096)))')
"$canopen" --iface "$iface" --fd --eds "$node=$eds" usdo write $node 0x2001 0 "$text"
back=$("$canopen" --iface "$iface" --fd --eds "$node=$eds" usdo read $node 0x2001)
[ "$back" = "$text" ] || { echo "USDO read back ${#back} bytes"; exit 1; }
by_sdo=$("$canopen" --iface "$iface" --eds "$node=$eds" sdo read $node 0x2001)
[ "$by_sdo" = "$text" ] || { echo "SDO read back ${#by_sdo} bytes"; exit 1; }
echo "ok: 4096 bytes written and read back by segmented USDO, and read by classic SDO"

if "$canopen" --iface "$iface" --fd --json usdo read $node 0x5FFF --type u8 \
    >/dev/null 2>/tmp/usdo-abort.json; then
    echo "reading a missing object succeeded"
    exit 1
fi
python3 -c 'import json; j = json.load(open("/tmp/usdo-abort.json")); assert j["abort_code"] == "0x06020000" and "USDO abort 0x33" in j["error"], j'
echo "ok: the missing object is USDO abort 0x33, CiA 301 0x06020000"

kill "$sim"
wait "$sim" 2>/dev/null || true
sleep 0.5
kill "$cd_pid"
wait "$cd_pid" 2>/dev/null || true
python3 - <<'PY'
lines = [l.split()[2] for l in open("/tmp/usdo-candump.log") if l.strip()]
fd = [f for f in lines if "##" in f]
requests = [f for f in fd if f.startswith("67F##")]
responses = [f for f in fd if f.startswith("58C##")]
full = lambda fs: [f for f in fs if len(f.split("##")[1]) == 1 + 128]
assert len(full(requests)) >= 4096 // 60, len(full(requests))
assert len(full(responses)) >= 4096 // 60, len(full(responses))
print("ok: candump -L shows", len(requests), "USDO requests and", len(responses),
      "responses as CAN FD frames,", len(full(requests)), "and", len(full(responses)),
      "of them 64-byte segments; e.g.", responses[0])
PY

set_mtu 16
if "$canopen" --iface "$iface" --fd usdo read $node 0x1008 2>/tmp/usdo-mtu16.err; then
    echo "usdo on MTU 16 succeeded"
    exit 1
fi
cat /tmp/usdo-mtu16.err
grep -q "FD not supported on $iface (MTU 16: classic CAN only" /tmp/usdo-mtu16.err
echo "ok: on MTU 16 the USDO command says FD is not supported"
