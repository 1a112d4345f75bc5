"""python-canopen's side of `vcan_drives` (crates/bench/src/bin/vcan_drives.rs): the SYNC every
PERIOD seconds (`network.sync.start(PERIOD)`) and, for each drive 1..N, RPDO4 mapped with the
target position 0x607A alone on COB-ID 0x500 + node, sent by its periodic PDO transmit
(`PdoMap.start(PERIOD)`): the frames this master's `Drive` cyclic streams send.

The mapping is set on python-canopen's side only (the simulated drives were set up by the
Rust run before, with the same layout), so nothing but the SYNC and the RPDOs goes on the bus.

Protocol on stdin/stdout: prints `READY` once connected and configured; on a `start` line
starts the SYNC and the RPDOs and prints `STARTED`; on `stop` (or end of input) stops them,
prints `STOPPED` and exits.

    sync_rpdo_bench.py --iface vcan0 --drives 8 --period 0.001 --eds eds/cia402-servo.eds \
        --targets 100,200,300,400,500,600,700,800
"""

import argparse
import sys

import canopen


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--iface", default="vcan0")
    ap.add_argument("--drives", type=int, default=8)
    ap.add_argument("--period", type=float, default=0.001)
    ap.add_argument("--eds", default="eds/cia402-servo.eds")
    ap.add_argument("--targets", default="",
                    help="comma-separated target positions, one per drive (default 0)")
    args = ap.parse_args()

    network = canopen.Network()
    network.connect(interface="socketcan", channel=args.iface)
    targets = [int(t) for t in args.targets.split(",") if t]
    targets += [0] * (args.drives - len(targets))
    pdos = []
    for n in range(1, args.drives + 1):
        node = canopen.RemoteNode(n, args.eds)
        network.add_node(node)
        rpdo = node.rpdo[4]
        rpdo.clear()
        rpdo.add_variable(0x607A)
        rpdo.cob_id = 0x500 + n
        rpdo.trans_type = 1
        rpdo.enabled = True
        rpdo[0x607A].raw = targets[n - 1]
        pdos.append(rpdo)
    print("READY", flush=True)
    started = False
    for line in sys.stdin:
        cmd = line.strip()
        if cmd == "start" and not started:
            network.sync.start(args.period)
            for rpdo in pdos:
                rpdo.start(args.period)
            started = True
            print("STARTED", flush=True)
        elif cmd == "stop":
            break
    for rpdo in pdos:
        rpdo.stop()
    network.sync.stop()
    network.disconnect()
    print("STOPPED", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
