"""python-canopen's side of the vcan SDO benchmark (crates/bench, binary `vcan_sdo`).

A RemoteNode (python-canopen 2.4.1) as the SDO client of a device already serving on the bus
(this project's simulator, started by `vcan_sdo`): COUNT expedited reads of 0x1000 (4 bytes), a
segmented upload and a block upload (`SdoClient.open(..., block_transfer=True)`, block size 127,
CRC requested) of 0x2001 holding SIZE bytes whose byte i is (13 i + 7) mod 251. Every value is
checked. With --marks, `BEGIN NAME` and `END NAME` lines (outside the timed code) bracket each
part. Prints `READY` once python-canopen is imported and connected (importing it takes
seconds in the TCG guest; that time is not measured), then one line with the elapsed time and
the CPU time of this process (all its threads: python-can's receive thread included) per part:

    RESULT expedited=S segmented=S block=S expedited_cpu=S segmented_cpu=S block_cpu=S

Exit status 1 when a transfer fails or returns wrong data.

usage: remote_sdo_bench.py [--iface vcan0] [--node-id 0x5c] [--count 1000] [--size 65536]
                           [--marks]
"""

import argparse
import struct
import sys
import time

import canopen


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--iface", default="vcan0")
    ap.add_argument("--node-id", type=lambda s: int(s, 0), default=0x5C)
    ap.add_argument("--count", type=int, default=1000)
    ap.add_argument("--size", type=int, default=65536)
    ap.add_argument("--marks", action="store_true",
                    help="print BEGIN NAME / END NAME around each timed part (vcan_sdo reads the "
                         "simulator thread's CPU time at these lines)")
    args = ap.parse_args()

    network = canopen.Network()
    network.connect(interface="socketcan", channel=args.iface)
    try:
        # No EDS needed: raw uploads by index and sub-index.
        node = canopen.RemoteNode(args.node_id, canopen.ObjectDictionary())
        network.add_node(node)
        sdo = node.sdo
        # Generous: the guest is emulated; this bounds only a missing response.
        sdo.RESPONSE_TIMEOUT = 5.0
        want = bytes((i * 13 + 7) % 251 for i in range(args.size))
        print("READY", flush=True)

        times = {}

        def start(name):
            if args.marks:
                print("BEGIN " + name, flush=True)
            return time.perf_counter(), time.process_time()

        def stop(name, t):
            times[name] = time.perf_counter() - t[0]
            times[name + "_cpu"] = time.process_time() - t[1]
            if args.marks:
                print("END " + name, flush=True)

        t = start("expedited")
        for _ in range(args.count):
            got = sdo.upload(0x1000, 0)
            if got != struct.pack("<I", 0x00020191):
                raise AssertionError(f"expedited read returned {got!r}")
        stop("expedited", t)

        t = start("segmented")
        got = sdo.upload(0x2001, 0)
        stop("segmented", t)
        if got != want:
            raise AssertionError(f"segmented upload returned {len(got)} bytes that differ")

        t = start("block")
        with sdo.open(0x2001, 0, "rb", buffering=0, block_transfer=True) as f:
            got = f.readall()
        stop("block", t)
        if got != want:
            raise AssertionError(f"block upload returned {len(got)} bytes that differ")

        print("RESULT " + " ".join(f"{k}={v:.6f}" for k, v in times.items()), flush=True)
    finally:
        network.disconnect()
    return 0


if __name__ == "__main__":
    sys.exit(main())
