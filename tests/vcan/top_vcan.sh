#!/usr/bin/env bash
# `canopen top` on SocketCAN: the view runs in tmux inside the guest with `--iface vcan0`,
# against `canopen simulate eds/burkert-generic.eds` (another process) on the same interface.
# The screen, read with `tmux capture-pane`, must show the node pre-operational, then
# operational after `o`, stopped after `x`, with the bus pane counting frames; `q` ends the view
# with exit status 0. Runs inside the rig (tests/vcan/run-all):
#   top_vcan.sh PATH/TO/canopen
set -euo pipefail
canopen=$1
iface=${CANOPEN_VCAN_IFACE:-vcan0}
node=21
sock=canopen-top-rig

"$canopen" --iface "$iface" simulate eds/burkert-generic.eds --node-id $node --duration 120 \
    >/dev/null 2>/tmp/top-sim.err &
sim=$!
cleanup() {
    tmux -L $sock kill-server 2>/dev/null || true
    kill $sim 2>/dev/null || true
}
trap cleanup EXIT
for _ in $(seq 60); do
    "$canopen" --iface "$iface" sdo read $node 0x1000 >/dev/null 2>&1 && break
    sleep 0.2
done

tmux -L $sock new-session -d -s top -x 100 -y 30
tmux -L $sock send-keys -t top "'$canopen' --iface $iface --hex top; echo TOP-EXIT=\$?" Enter
screen() { tmux -L $sock capture-pane -p -t top; }
# `wait_for WHAT GREP-REGEX`: up to 30 s for the screen to match (the guest is slow).
wait_for() {
    for _ in $(seq 150); do
        if screen | grep -q -- "$2"; then
            echo "ok: $1"
            return 0
        fi
        sleep 0.2
    done
    echo "never saw $1; the screen:"
    screen
    exit 1
}
row="> *$node .*"
wait_for "node $node pre-operational on $iface" "${row}PRE-OP"
screen | grep -q "$iface" || { echo "the view does not name $iface"; screen; exit 1; }
tmux -L $sock send-keys -t top o
wait_for "node $node operational after o" "${row}OPERATIONAL"
tmux -L $sock send-keys -t top x
wait_for "node $node stopped after x" "${row}STOPPED"
screen | grep -Eq "^bus: [0-9]+ fr/s" || { echo "no frame rate on the bus line"; screen; exit 1; }
tmux -L $sock send-keys -t top q
wait_for "top ended by q with status 0" "^TOP-EXIT=0"
screen
