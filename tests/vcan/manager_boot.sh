#!/usr/bin/env bash
# The network manager on vcan0: `canopen --iface vcan0 boot bus.toml --json` boots 16 valves
# (nodes 2..17) whose simulators run in processes of their own (`canopen --iface vcan0 simulate`,
# one per valve): node 3 has the wrong vendor-ID (error D), node 4 is absent (B), node 5's
# firmware refuses a configuration write (J with the abort code), node 6 is configured already
# (0x1020 matches: skipped), node 17 is lost after the boot and restarted (NMT reset
# communication, booted again when its boot-up comes). The JSON report is checked field by field,
# the candump of the whole run for the reset and the re-boot. Then a value changed behind the
# master's back: `canopen audit` finds it, `audit --fix` repairs it, a third audit is clean.
# Runs inside the rig (tests/vcan/run-all); usage:
#   manager_boot.sh PATH/TO/canopen
set -euo pipefail
canopen=$1
data=$PWD/crates/manager/tests/data
dir=/tmp/manager-boot
mkdir -p "$dir"

# The valves' DCF with a 500 ms heartbeat (fifteen devices at 10 Hz load the emulated guest).
# The devices as they come from the factory: that DCF without its parameter values. Node 5's
# firmware has 0x2002 read-only where its DCF says rw.
awk '/^\[/{s=$0} s=="[1017]" && /^ParameterValue=/{$0="ParameterValue=500"} {print}' "$data/valve.dcf" >"$dir/valve.dcf"
grep -A7 '^\[1017\]' "$dir/valve.dcf" | grep -q 'ParameterValue=500'
data=$dir
sed '/^ParameterValue=/d' "$data/valve.dcf" >"$dir/factory.dcf"
awk '/^\[/{s=$0} s=="[2002]" && /^AccessType=/{$0="AccessType=ro"} {print}' "$dir/factory.dcf" >"$dir/factory-ro.dcf"
grep -A4 '^\[2002\]' "$dir/factory-ro.dcf" | grep -q 'AccessType=ro'

# The description: generous timeouts for the emulated guest. Node 3 and 5 are optional, so the
# others start together; the heartbeat consumer waits three producer periods.
{
    printf '[master]\nnode_id = 1\nsdo_timeout_ms = 3000\nboot_timeout_ms = 4000\nheartbeat_consumer_percent = 300\n'
    for n in $(seq 2 17); do
        printf '\n[[slave]]\nnode_id = %d\ndcf = "%s"\n' "$n" "$data/valve.dcf"
        case $n in
            3) printf 'mandatory = false\n[slave.identity]\nvendor_id = 0x40\n' ;;
            4 | 5) printf 'mandatory = false\n' ;;
            17) printf 'mandatory = true\nrestart_on_loss = true\n' ;;
            *) printf 'mandatory = true\n' ;;
        esac
    done
} >"$dir/bus.toml"

pids=()
cleanup() {
    local rc=$?
    for p in "${pids[@]}" "${dump:-}"; do kill "$p" 2>/dev/null || true; done
    if [ "$rc" != 0 ]; then
        for f in "$dir/boot.json" "$dir/audit.json"; do
            [ -s "$f" ] && { echo "--- $f"; cat "$f"; echo; }
        done
    fi
    return "$rc"
}
trap cleanup EXIT
sim() { # node file
    "$canopen" --iface vcan0 simulate "$2" --node-id "$1" >/dev/null &
    echo $!
}

candump -L vcan0 >"$dir/candump.log" &
dump=$!
for n in $(seq 2 17); do
    case $n in
        4) continue ;;
        5) file=$dir/factory-ro.dcf ;;
        6) file=$data/valve.dcf ;;
        *) file=$dir/factory.dcf ;;
    esac
    p=$(sim "$n" "$file")
    pids+=("$p")
    [ "$n" = 17 ] && sim17=$p
done
# Ready when each device answers an SDO read (processes start slowly in the guest).
for n in $(seq 2 17); do
    [ "$n" = 4 ] && continue
    for _ in $(seq 60); do
        if "$canopen" --iface vcan0 sdo read "$n" 0x1000 0 >/dev/null 2>&1; then break; fi
        sleep 0.5
    done
done
echo "15 simulators answer"

# `wait_heartbeat NODE STATE SECONDS [PID]`: a heartbeat of NODE carrying STATE arrives (while
# process PID, the master, still runs).
wait_heartbeat() {
    python3 - "$@" <<'EOF'
import os, socket, struct, sys, time
node, state, secs = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3])
pid = int(sys.argv[4]) if len(sys.argv) > 4 else None
s = socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)
s.setsockopt(socket.SOL_CAN_RAW, socket.CAN_RAW_FILTER, struct.pack("=II", 0x700 + node, 0x7FF))
s.bind(("vcan0",))
s.settimeout(0.5)
end = time.time() + secs
while time.time() < end:
    try:
        can_id, dlc, data = struct.unpack("=IB3x8s", s.recv(16))
    except socket.timeout:
        try:
            ended = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()[0] == "Z"
        except OSError:
            ended = True
        if pid is not None and ended:
            sys.exit(f"the master ended before node {node} sent heartbeat {state:#04x}")
        continue
    if dlc == 1 and data[0] == state:
        sys.exit(0)
sys.exit(f"no heartbeat {state:#04x} from node {node} within {secs} s")
EOF
}

t0=$EPOCHREALTIME
"$canopen" --iface vcan0 --json boot "$dir/bus.toml" --supervise 30 >"$dir/boot.json" &
master=$!
pids+=("$master")
# Node 17 operational (the start-all came), then it drops off the bus and comes back fresh.
wait_heartbeat 17 5 180 "$master"
echo "node 17 operational after $(python3 -c "print(round($EPOCHREALTIME - $t0, 1))") s"
kill "$sim17"
sleep 5
pids+=("$(sim 17 "$dir/factory.dcf")")
wait_heartbeat 17 5 25 "$master"
echo "node 17 operational again"
wait "$master"
echo "boot and supervision done after $(python3 -c "print(round($EPOCHREALTIME - $t0, 1))") s"

python3 - "$dir/boot.json" "$dir/candump.log" <<'EOF'
import json, sys
j = json.load(open(sys.argv[1]))
by = {s["node_id"]: s for s in j["slaves"]}
assert sorted(by) == list(range(2, 18)), sorted(by)
assert j["mandatory_ok"] is True, j
def check(n, **want):
    s = by[n]
    for k, v in want.items():
        assert s[k] == v, (n, k, s[k], v, s)
    print(f"ok: node {n}: " + ", ".join(f"{k}={v}" for k, v in want.items()))
for n in [2, *range(7, 18)]:
    check(n, status="operational", error_code=None, step=None, object=None, abort_code=None,
          configuration="written", values_written=4, error_control="heartbeat 1500 ms",
          mandatory=True, software=None)
check(3, status="failed", error_code="D", step="identity", object="0x1018:01",
      abort_code=None, configuration=None, mandatory=False)
assert "0x00000039" in by[3]["detail"] and "0x00000040" in by[3]["detail"], by[3]
check(4, status="absent", error_code="B", step="device-present", object="0x1000:00",
      abort_code="0x05040000", mandatory=False)
check(5, status="failed", error_code="J", step="configuration", object="0x2002:00",
      abort_code="0x06010002", mandatory=False)
check(6, status="operational", error_code=None, configuration="verified", values_written=0)
# The candump: node 17 lost, reset communication (0x82) sent to it, its boot-up, then the
# master configured it again (an SDO download to 0x2001 after the boot-up).
frames = [l.split()[2] for l in open(sys.argv[2]) if len(l.split()) == 3]
reset = frames.index("000#8211")
boot_up = frames.index("711#00", reset)
again = [i for i, f in enumerate(frames) if f.startswith("611#2301200011100000") and i > boot_up]
assert again, "no configuration of node 17 after its boot-up"
print(f"ok: candump: reset communication to 17 at frame {reset}, boot-up at {boot_up}, 0x2001 written again at {again[0]}")
EOF
[ "$("$canopen" --iface vcan0 sdo read 17 0x2001 0 --type u32)" = 4113 ]
echo "ok: node 17 holds its configuration again (0x2001 = 4113)"

# Behind the master's back: node 9's close delay changed by another process.
"$canopen" --iface vcan0 sdo write 9 0x2001 0 77 --type u32
audit() { "$canopen" --iface vcan0 --json audit "$dir/bus.toml" "$@" >"$dir/audit.json" || true; cat "$dir/audit.json"; }
check_audit() { # fixed-expected
    python3 - "$dir/audit.json" "$1" <<'EOF'
import json, sys
j = json.load(open(sys.argv[1]))
phase = sys.argv[2]
by = {s["node_id"]: s for s in j["slaves"]}
assert j["clean"] is False  # nodes 3, 4 and 5 never got their configuration
for n in [2, 6, 7, 8, *range(10, 18)]:
    assert by[n]["differences"] == [] and by[n]["unreadable"] == [], by[n]
    assert by[n]["checked"] == 6, by[n]
d = by[9]["differences"]
if phase == "clean":
    assert d == [], d
    print("ok: audit: node 9 matches its DCF again")
else:
    assert len(d) == 1, d
    d = d[0]
    assert (d["object"], d["name"], d["type"], d["expected"], d["actual"]) == (
        "0x2001:00", "Close Delay", "Unsigned32", "4105", "77"), d
    assert d["fixed"] == (True if phase == "fix" else None), d
    print(f"ok: audit ({phase}): node 9 0x2001:00 Close Delay expected 4105, actual 77, fixed={d['fixed']}")
assert len(by[4]["unreadable"]) == 6 and by[4]["unreadable"][0]["abort_code"] == "0x05040000", by[4]
EOF
}
audit >/dev/null
check_audit find
audit --fix >/dev/null
check_audit fix
[ "$("$canopen" --iface vcan0 sdo read 9 0x2001 0 --type u32)" = 4105 ]
audit >/dev/null
check_audit clean
echo "manager_boot: boot report, restart on loss and audit checked on vcan0"
