#!/usr/bin/env bash
# The GEMÜ 1436 cPos over DeviceNet on vcan0: `canopen cpos simulate` (the simulated cPos
# behind a DeviceNet slave) in one process, `canopen cpos --iface vcan0 ...` as the master in
# others, on the real kernel CAN stack. candump records the traffic; Wireshark's DeviceNet
# dissector (tshark) then reads the capture and must agree with the devicenet crate's decoding
# (devicenet_tshark.py). Runs inside the rig (tests/vcan/run-all); usage:
#   cpos_devicenet.sh PATH/TO/canopen PATH/TO/candump_fields
set -euo pipefail
canopen=$1
fields=$2
# A 50 ms poll cycle (the connection times out after 4 cycles): processes under TCG emulation
# are scheduled too late for 10 ms.
dn=(--iface vcan0 cpos --mac 63 --cycle-ms 50 --diagnostic-attribute 0x64/1/1)

candump -L vcan0 >/tmp/devicenet.log &
dump=$!
"$canopen" --iface vcan0 cpos --mac 63 simulate >/tmp/cpos-sim.log &
sim=$!
trap 'kill "$sim" "$dump" 2>/dev/null || true' EXIT

# Ready when the simulated cPos has passed its Duplicate MAC ID check (2 s).
for _ in $(seq 100); do
    if grep -q "on line" /tmp/cpos-sim.log; then break; fi
    sleep 0.2
done
cat /tmp/cpos-sim.log

check() { # check JSON PYTHON-EXPRESSION over j
    python3 -c 'import json,sys; j=json.loads(sys.argv[1]); assert eval(sys.argv[2]), (sys.argv[2], j)' "$1" "$2"
    echo "ok: $2"
}

check "$("$canopen" --json "${dn[@]}" set Mode manual)" 'j["value"] == 2 and j["label"] == "Manual"'
# The simulator keeps its state between commands (one process).
[ "$("$canopen" "${dn[@]}" get Mode)" = "Mode (0x0064) = 2 (Manual)" ]
echo "ok: get Mode after set"
check "$("$canopen" --json "${dn[@]}" set Mode auto)" 'j["value"] == 1'
check "$("$canopen" --json "${dn[@]}" errors)" 'j["error_list"] == [] and j["active_errors"] == []'
# A refusal with its external diagnostic, read over the explicit connection.
if out=$("$canopen" "${dn[@]}" set openTight 10 2>&1); then exit 1; fi
echo "$out" | grep -q "below the minimum" && echo "ok: range checked before sending"
out=$("$canopen" --json "${dn[@]}" action init-valve)
check "$out" 'j["ok"] and j["events"][-1]["event"] in ("ended", "parameter")'
check "$out" 'any(e.get("status", "").startswith("determining the closed position") for e in j["events"])'
if out=$("$canopen" "${dn[@]}" action no-init open-fast 2>&1); then exit 1; fi
echo "$out" | grep -q "diagnostic 0x42" && echo "ok: NoInit on the initialised valve refused with 0x42"
out=$("$canopen" "${dn[@]}" action go-close)
echo "$out" | grep -q "GoClose: ended" && echo "ok: go-close approach and adopt"
# The device's sizes are checked at connect.
if out=$("$canopen" "${dn[@]}" --send 5 --receive 3 get Mode 2>&1); then exit 1; fi
echo "$out" | grep -q "the device is set to send 13 / receive 11 bytes, expected send 5 / receive 3" &&
    echo "ok: size check at connect"
# monitor decodes DeviceNet while a client polls (a GoOpen approach, adopted after 2 s; the
# client needs its 2 s Duplicate MAC ID check and the connect before it polls).
"$canopen" "${dn[@]}" action go-open >/dev/null &
client=$!
for _ in $(seq 40); do
    "$canopen" --iface vcan0 monitor --devicenet --duration 0.5 >/tmp/monitor.log
    if grep -q "DeviceNet poll response" /tmp/monitor.log; then break; fi
done
wait "$client"
grep -m 4 "DeviceNet" /tmp/monitor.log
grep -q "DeviceNet poll command to MAC 63: 00 " /tmp/monitor.log
grep -q "DeviceNet poll response from MAC 63: 81 " /tmp/monitor.log
echo "ok: monitor --devicenet"

# A second device with MAC 63 sees the first one's answer to its check and stays off line.
timeout 5 "$canopen" --iface vcan0 cpos --mac 63 simulate --duration 3 >/tmp/cpos-twin.log || true
cat /tmp/cpos-twin.log
grep -q "duplicate MAC ID: response" /tmp/cpos-twin.log && ! grep -q "on line" /tmp/cpos-twin.log
echo "ok: duplicate MAC ID detected by the second device"
# Connection loss: the cPos goes away, the master gives up connecting.
kill "$sim"
wait "$sim" 2>/dev/null || true
if out=$("$canopen" "${dn[@]}" --connect-timeout 4 get Mode 2>&1); then exit 1; fi
echo "$out" | grep -q "no DeviceNet connection to MAC 63" && echo "ok: $out"

sleep 0.5
kill "$dump"
wait "$dump" 2>/dev/null || true
python3 tests/vcan/devicenet_tshark.py /tmp/devicenet.log "$fields"
echo "cpos_devicenet: all commands ok against the simulated cPos over DeviceNet on vcan0"
