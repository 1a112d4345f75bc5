#!/usr/bin/env bash
# CAN FD frames on vcan0 reach `canopen record` and `canopen monitor`: with the interface's MTU
# at 72 (set here if it is not, and set back at the end), can-utils' `cansend` puts CAN FD
# frames (11- and 29-bit identifiers, flags, 4 to 64 bytes) and a classic frame on the bus
# while `canopen --iface vcan0 record` and `monitor --json` run. The log must hold every frame,
# the FD ones in candump's FD syntax exactly as `candump -L` (the independent reference, on the
# side) writes them; `monitor` shows them; `canopen replay` of the log sends them all again (the
# FD ones as FD frames, seen by `candump -L`), and on the interface set to MTU 16 skips the FD
# ones saying why. Runs inside the rig (tests/vcan/run-all):
#   record_fd_cli.sh PATH/TO/canopen
set -euo pipefail
canopen=$1
iface=${CANOPEN_VCAN_IFACE:-vcan0}

mtu=$(cat "/sys/class/net/$iface/mtu")
pids=()
cleanup() {
    for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
    if [ "$(cat "/sys/class/net/$iface/mtu")" != "$mtu" ]; then
        ip link set "$iface" down && ip link set "$iface" mtu "$mtu" && ip link set "$iface" up
        echo "MTU of $iface set back to $mtu"
    fi
}
trap cleanup EXIT
if [ "$mtu" != 72 ]; then
    echo "MTU of $iface is $mtu: setting 72 (CAN FD)"
    ip link set "$iface" down
    ip link set "$iface" mtu 72
    ip link set "$iface" up
fi

candump -L "$iface" >/tmp/fd-candump.log &
pids+=($!)
"$canopen" --iface "$iface" record -o /tmp/fd-record.log --duration 15 2>/tmp/fd-record.err &
rec=$!
pids+=($rec)
"$canopen" --iface "$iface" --json monitor --duration 15 >/tmp/fd-monitor.json &
mon=$!
pids+=($mon)

# Ready when record has opened its socket and monitor shows a probe frame.
for _ in $(seq 100); do
    grep -q '^recording' /tmp/fd-record.err && break
    sleep 0.1
done
for _ in $(seq 60); do
    cansend "$iface" 7FF#01
    sleep 0.2
    grep -q '7FF#01' /tmp/fd-monitor.json && break
done
grep -q '7FF#01' /tmp/fd-monitor.json || { echo "monitor never showed the probe"; exit 1; }

data64=$(python3 -c 'print("".join(f"{i:02X}" for i in range(64)))')
cansend "$iface" '123##1112233445566778899AABBCC'
cansend "$iface" '12345678##0DEADBEEF'
cansend "$iface" "456##2$data64"
cansend "$iface" 705#05

wait "$rec" || { cat /tmp/fd-record.err; exit 1; }
wait "$mon"
kill "${pids[0]}"
wait "${pids[0]}" 2>/dev/null || true

echo "--- record: $(cat /tmp/fd-record.err | tr '\n' ' ')"
echo "--- record log:"
cat /tmp/fd-record.log
echo "--- candump -L:"
cat /tmp/fd-candump.log

python3 - <<'PY'
import json
def frames(path):
    return [line.split()[2] for line in open(path) if line.strip()]
ours, ref = frames("/tmp/fd-record.log"), frames("/tmp/fd-candump.log")
fd_ours = [f for f in ours if "##" in f]
fd_ref = [f for f in ref if "##" in f]
assert len(fd_ref) == 3, fd_ref
assert fd_ours == fd_ref, (fd_ours, fd_ref)
print("ok: the 3 CAN FD frames are in the log as candump -L writes them:", fd_ours)
assert "705#05" in ours and "7FF#01" in ours, ours
assert [f for f in ours if f in ("705#05",)] == ["705#05"]
print("ok: the classic frames too; the log has", len(ours), "frames, candump", len(ref))
mon = [json.loads(l) for l in open("/tmp/fd-monitor.json") if l.strip()]
fd_mon = [m["frame"] for m in mon if "##" in m["frame"]]
assert fd_mon == fd_ref, (fd_mon, fd_ref)
assert all(m["decoded"] == "CAN FD frame (not decoded)" for m in mon if "##" in m["frame"])
print("ok: monitor shows them")
PY
grep -q '(3 of them CAN FD) recorded' /tmp/fd-record.err
echo "ok: record counts them: $(cat /tmp/fd-record.err | tail -1)"

# Replay on the FD interface: the FD frames go out again, as candump -L on the side sees them.
candump -L "$iface" >/tmp/fd-replayed.log &
cd_pid=$!
pids+=($cd_pid)
sleep 0.5
r=$("$canopen" --iface "$iface" --json replay /tmp/fd-record.log 2>/tmp/fd-replay.err)
sleep 0.5
kill "$cd_pid"
wait "$cd_pid" 2>/dev/null || true
echo "replay: $r $(cat /tmp/fd-replay.err)"
python3 - "$r" <<'PY'
import json, sys
j = json.loads(sys.argv[1])
assert j["sent_fd"] == 3 and j["skipped_fd"] == 0 and j["sent"] >= 5, j
replayed = [l.split()[2] for l in open("/tmp/fd-replayed.log") if "##" in l]
recorded = [l.split()[2] for l in open("/tmp/fd-record.log") if "##" in l]
# The kernel of the guest may set FDF (flags bit 2) on received frames: compare without it.
def strip(f):
    ident, rest = f.split("##")
    return ident + "##" + format(int(rest[0], 16) & 3, "X") + rest[1:]
assert [strip(f) for f in replayed] == [strip(f) for f in recorded], (replayed, recorded)
print("ok: replay sends the 3 FD frames again, candump -L sees them:", replayed)
PY

# On a classic-only interface (MTU 16) the FD frames are skipped, saying why.
ip link set "$iface" down
ip link set "$iface" mtu 16
ip link set "$iface" up
r=$("$canopen" --iface "$iface" --json replay /tmp/fd-record.log 2>/tmp/fd-replay16.err)
echo "replay on MTU 16: $r $(cat /tmp/fd-replay16.err)"
python3 -c 'import json,sys; j=json.loads(sys.argv[1]); assert j["skipped_fd"] == 3 and j["sent_fd"] == 0 and j["sent"] >= 2, j' "$r"
grep -q 'FD not supported on '"$iface"' (MTU 16' /tmp/fd-replay16.err
echo "ok: on MTU 16 replay skips the 3 FD frames: FD not supported"
ip link set "$iface" down
ip link set "$iface" mtu 72
ip link set "$iface" up
