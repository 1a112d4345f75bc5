#!/usr/bin/env python3
"""N expedited SDO reads with canola and with python-canopen, against one simulated device.

canola's device simulator (the Bürkert EDS, node 5) is served on a UDP multicast bus in
python-can's `udp_multicast` format (`SimDevice.serve("udp:GROUP:PORT")`); canola's client
joins it with its `udp:` bus spec, python-canopen with python-can's `udp_multicast` interface
(`hop_limit=0`: the kernel loops the frames back to this machine, nothing goes on the wire).
Both read the producer heartbeat time 0x1017 (an expedited upload) N times, one after the
other; each prints its total time and time per read, and the ratio.

    .venv/bin/python crates/python/bench/sdo_bench.py [-n 2000]

Not part of the test suite (timings depend on the machine and its load).
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import canopen

import canola

EDS = str(Path(__file__).resolve().parents[3] / "eds" / "burkert-generic.eds")
NODE = 5


def bench_canola(spec: str, n: int) -> float:
    with canola.Network.open(spec) as net:
        node = net.add_node(NODE, EDS)
        var = node.sdo[0x1017]
        for _ in range(20):  # warm-up
            var.raw
        start = time.perf_counter()
        for _ in range(n):
            var.raw
        elapsed = time.perf_counter() - start
    return elapsed


def bench_python_canopen(group: str, port: int, n: int) -> float:
    net = canopen.Network()
    net.connect(interface="udp_multicast", channel=group, port=port, hop_limit=0)
    try:
        node = net.add_node(NODE, EDS)
        var = node.sdo[0x1017]
        for _ in range(20):  # warm-up
            var.raw
        start = time.perf_counter()
        for _ in range(n):
            var.raw
        return time.perf_counter() - start
    finally:
        net.disconnect()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-n", type=int, default=2000, help="reads per client (default 2000)")
    parser.add_argument("--group", default="239.74.163.33", help="multicast group")
    parser.add_argument("--port", type=int, default=20000 + os.getpid() % 9000)
    args = parser.parse_args()
    spec = f"udp:{args.group}:{args.port}"
    with canola.SimDevice.from_eds(EDS, NODE).serve(spec):
        t_canola = bench_canola(spec, args.n)
        t_pc = bench_python_canopen(args.group, args.port, args.n)
    n = args.n
    print(f"{n} expedited SDO reads of 0x1017 from canola's simulator over {spec}")
    print(f"canola:         {t_canola:8.3f} s  {t_canola / n * 1e6:8.1f} µs/read")
    print(f"python-canopen: {t_pc:8.3f} s  {t_pc / n * 1e6:8.1f} µs/read")
    ratio = t_canola / t_pc
    print(f"time ratio canola / python-canopen: {ratio:.2f} ({'canola' if ratio > 1 else 'python-canopen'} slower)")


if __name__ == "__main__":
    main()
