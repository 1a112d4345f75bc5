#!/usr/bin/env bash
# Proves the guest's CAN bus works with tools independent of this project: can-utils
# (cansend/candump) and raw AF_CAN sockets from the standard library of the host's Python.
# Runs inside the rig (`tests/vcan/rig shell-check`); fails outside it.
set -euo pipefail

ip -details link show vcan0
[ -d /sys/class/net/vcan0 ] || { echo "shell-check: no vcan0" >&2; exit 1; }

# candump: wait until its socket is registered on vcan0 before sending.
dump=/tmp/candump.log
candump -L -n 2 -T 20000 vcan0 >"$dump" &
pid=$!
for _ in $(seq 200); do
    grep -q '^ *vcan0 ' /proc/net/can/rcvlist_all && break
    sleep 0.05
done
cansend vcan0 123#DEADBEEF
cansend vcan0 1ABCDE01#0102030405060708
wait "$pid"
cat "$dump"
grep -q ' vcan0 123#DEADBEEF$' "$dump"
grep -q ' vcan0 1ABCDE01#0102030405060708$' "$dump"
echo "shell-check: can-utils ok"

# Raw AF_CAN with nothing but the Python standard library (struct can_frame: id, dlc, data).
python3 - <<'PY'
import socket, struct
fmt = "=IB3x8s"
a = socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)
b = socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)
a.bind(("vcan0",)); b.bind(("vcan0",))
b.settimeout(10)
a.send(struct.pack(fmt, 0x601, 8, bytes([0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0])))
can_id, dlc, data = struct.unpack(fmt, b.recv(16))
assert (can_id, dlc, data) == (0x601, 8, bytes([0x40, 0x00, 0x10, 0, 0, 0, 0, 0])), (hex(can_id), dlc, data)
print("shell-check: raw AF_CAN ok (0x601 sent on one socket, received on another)")
PY
