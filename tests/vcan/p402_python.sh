#!/usr/bin/env bash
# python-canopen 2.4.1's BaseNode402 on vcan0 as the master of the simulated servo
# (`canopen simulate eds/cia402-servo.eds`, another process): the walk of the CLI test
# crates/cli/tests/drive_python.rs on the UDP bus (state machine, velocity and position modes, a
# profile-position move, homing, quick stop, a fault and its reset), here over real SocketCAN.
# Runs inside the rig (tests/vcan/run-all):
#   p402_python.sh PYTHON PATH/TO/canopen
set -euo pipefail
py=$1
canopen=$2
iface=${CANOPEN_VCAN_IFACE:-vcan0}
eds=eds/cia402-servo.eds

"$canopen" --iface "$iface" simulate "$eds" --node-id 5 --duration 120 \
    >/dev/null 2>/tmp/p402-sim.err &
sim=$!
trap 'kill $sim 2>/dev/null || true' EXIT
for _ in $(seq 50); do
    if "$canopen" --iface "$iface" sdo read 5 0x1000 >/dev/null 2>&1; then break; fi
    sleep 0.1
done

out=$("$py" crates/cli/tests/py/p402_drive.py socketcan "$iface" "$eds")
echo "$out"
check() {
    grep -qx "$1" <<<"$out" || { echo "p402: no line '$1'"; cat /tmp/p402-sim.err; exit 1; }
}
check "INITIAL SWITCH_ON_DISABLED"
check "STATE READY_TO_SWITCH_ON"
check "STATE SWITCHED_ON"
check "STATE OPERATION_ENABLED"
check "MODE PROFILED_VELOCITY"
check "MODE PROFILED_POSITION"
check "ACK True"
check "REACHED True"
check "HOMED True"
check "AFTER_QUICKSTOP SWITCH_ON_DISABLED"
check "FAULTED True"
check "ERROR_CODE 0x8612"
# python-canopen #261: reset_from_fault enables the drive again (see drive_python.rs).
check "AFTER_RESET OPERATION_ENABLED"
pos=$(sed -n 's/^POSITION //p' <<<"$out" | tail -1)
[ "${pos#-}" -ge 2990 ] && [ "${pos#-}" -le 3010 ] || { echo "p402: position $pos, not 3000"; exit 1; }
echo "p402: BaseNode402 drove the simulated servo on $iface"
