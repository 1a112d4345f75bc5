#!/usr/bin/env bash
# The `canopen burkert ...` commands against `canopen simulate eds/burkert-generic.eds` on vcan0
# (issue 7): two processes of the CLI on the real kernel CAN stack, one simulating the Bürkert
# device, one acting as the master. Runs inside the rig (tests/vcan/run-all); usage:
#   burkert_cli.sh PATH/TO/canopen
set -euo pipefail
canopen=$1
node=9

"$canopen" --iface vcan0 simulate eds/burkert-generic.eds --node-id "$node" &
sim=$!
trap 'kill "$sim" 2>/dev/null || true' EXIT

# Ready when the device answers an SDO read (the guest is slow to start processes).
for _ in $(seq 60); do
    if "$canopen" --iface vcan0 sdo read "$node" 0x1000 0 >/dev/null 2>&1; then break; fi
    sleep 0.5
done
"$canopen" --iface vcan0 sdo read "$node" 0x1018 1

# `check JSON PYTHON-EXPRESSION`: the expression over `j` (the parsed JSON) must hold.
check() {
    python3 -c 'import json,sys; j=json.loads(sys.argv[1]); assert eval(sys.argv[2]), (sys.argv[2], j)' "$1" "$2"
    echo "ok: $2"
}
status() { "$canopen" --iface vcan0 --json burkert status "$node"; }

s=$(status)
check "$s" 'j["node"] == 9 and j["status"]["ne107"]["value"] == 0'
check "$s" 'j["led"]["colour"] == "white" and j["led"]["mode"] == "namur"'
check "$s" 'j["communication"]["can_operation_status"] == "pre-operational"'
check "$s" 'j["description"]["device_name"] == "Generic device"'

"$canopen" --iface vcan0 --json burkert maintenance "$node" on
s=$(status)
check "$s" 'j["maintenance"] is True and j["status"]["ne107"]["value"] == 2'
check "$s" 'j["led"]["colour"] == "blue"'
"$canopen" --iface vcan0 --json burkert maintenance "$node" off

"$canopen" --iface vcan0 --json burkert led "$node" --mode fixed --colour '#00FFFF'
s=$(status)
check "$s" 'j["led"]["mode"] == "fixed" and j["led"]["colour"] == "#00FFFF" and j["led"]["code"] == 0x00FFFF00'

"$canopen" --iface vcan0 --json burkert locate "$node"
s=$(status)
check "$s" 'j["locating"] is True and j["led"]["flashing"] is True'
# A second locate while the first still stands: the CLI writes 0 first, then 1.
"$canopen" --iface vcan0 --json burkert locate "$node"
check "$(status)" 'j["locating"] is True'

"$canopen" --iface vcan0 --json burkert logbook "$node" -o /tmp/logbook.xml
head -c 100 /tmp/logbook.xml; echo
python3 -c 'import sys; d=open("/tmp/logbook.xml").read(); assert d.startswith("<?xml") and "</" in d and len(d) > 1000, len(d)'
# Operational: the sensor values go out in TPDO1, which `monitor` decodes through the EDS.
"$canopen" --iface vcan0 nmt start "$node"
"$canopen" --iface vcan0 --eds "$node=eds/burkert-generic.eds" monitor --duration 2.5 >/tmp/monitor.log
grep -m 3 "TPDO" /tmp/monitor.log
grep -q "TPDO1 node $node: Sensor Value 1 / Value = .*, Sensor Value 2 / Value = " /tmp/monitor.log
check "$(status)" 'j["communication"]["can_operation_status"] == "operational"'

# New node-ID through 0x2001 sub 2, active after a communication reset through 0x2001 sub 4.
"$canopen" --iface vcan0 sdo write "$node" 0x2001 2 10 --type u8
"$canopen" --iface vcan0 sdo write "$node" 0x2001 4 1 --type u8 || true  # may reset before answering
for _ in $(seq 20); do
    if "$canopen" --iface vcan0 sdo read 10 0x2001 2 >/dev/null 2>&1; then break; fi
    sleep 0.5
done
[ "$("$canopen" --iface vcan0 sdo read 10 0x2001 2 --type u8)" = 10 ]
echo "ok: the device answers as node 10 after the reset"
echo "burkert_cli: all commands ok against the simulated Bürkert device on vcan0"
