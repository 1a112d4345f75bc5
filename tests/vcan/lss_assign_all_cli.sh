#!/usr/bin/env bash
# `canopen lss assign-all` against two unconfigured LSS slaves that, as real slaves do, answer
# Fastscan in LSS configuration state (`canopen lss --unconfigured 2 --real-slaves simulate` in
# another process), on vcan0; then `canopen scan` finds both under their new node-IDs. candump
# records the bus meanwhile: every switch mode global the master sends is on the wire. Runs
# inside the rig (tests/vcan/run-all); usage:
#   lss_assign_all_cli.sh PATH/TO/canopen
set -euo pipefail
canopen=$1

candump -L vcan0 >/tmp/lss-assign.log &
dump=$!
"$canopen" --iface vcan0 lss --unconfigured 2 --real-slaves simulate &
sim=$!
trap 'kill "$sim" "$dump" 2>/dev/null || true' EXIT

# Ready when an unconfigured slave answers (the guest is slow to start processes).
for _ in $(seq 60); do
    if "$canopen" --iface vcan0 --json lss identify-non-configured | grep -q '"present":true'; then break; fi
    sleep 0.5
done

show_log() {
    echo "--- candump (last 80 of $(wc -l </tmp/lss-assign.log) frames)"
    tail -80 /tmp/lss-assign.log
}

check() {
    python3 -c 'import json,sys; j=json.loads(sys.argv[1]); assert eval(sys.argv[2]), (sys.argv[2], j)' "$1" "$2"
    echo "ok: $2"
}

# Fastscan steps of 100 ms: answers under TCG emulation come in about 1 ms but at times after
# more than 60 ms, and an answer later than the step timeout is taken for the next step's.
# A transmit-only command: its frame is on the bus when the process ends.
"$canopen" --iface vcan0 lss switch-global waiting

t0=$EPOCHREALTIME
a=$("$canopen" --iface vcan0 --json lss --step-timeout 100 assign-all --first 20 --last 30) || { show_log; exit 1; }
echo "assign-all took $(( (${EPOCHREALTIME/./} - ${t0/./}) / 1000 )) ms: $a"
check "$a" '[e["node_id"] for e in j["assigned"]] == [20, 21]' || { show_log; exit 1; }
check "$a" 'sorted(e["serial"] for e in j["assigned"]) == [1001, 1002]'
check "$a" 'j["stopped"] is None and all(e["stored"] for e in j["slaves"])'

# Nobody is left unconfigured.
check "$("$canopen" --iface vcan0 --json lss identify-non-configured)" 'j["present"] is False'

s=$("$canopen" --iface vcan0 --json scan)
echo "scan: $s"
check "$s" 'sorted(n["node"] for n in j) == [20, 21]'
check "$s" 'sorted(n["serial"] for n in j) == [1001, 1002]'

kill "$dump"
wait "$dump" 2>/dev/null || true
waiting=$(grep -c ' 7E5#0400000000000000$' /tmp/lss-assign.log || true)
configure=$(grep -c ' 7E5#11' /tmp/lss-assign.log || true)
echo "candump: $(wc -l </tmp/lss-assign.log) frames, $configure configure node-ID, $waiting switch mode global (waiting)"
# How long the slaves took to answer Fastscan (request to each answer), for the step timeout.
python3 - /tmp/lss-assign.log <<'PY'
import sys
sent, lat = None, []
for line in open(sys.argv[1]):
    ts, _, frame = line.split()
    t = float(ts.strip("()"))
    if frame.startswith("7E5#51"):
        sent = t
    elif frame.startswith("7E4#4F") and sent is not None:
        lat.append((t - sent) * 1000)
lat.sort()
if lat:
    print(f"Fastscan answers: {len(lat)}, latency median {lat[len(lat) // 2]:.2f} ms, max {lat[-1]:.2f} ms")
PY
# The lone switch-global, assign-all's first, one per configured slave and the last.
[ "$configure" -eq 2 ]
[ "$waiting" -ge 5 ]
