"""Interop: python-canopen's RemoteNode (this process) as the client of this project's device
simulator (`canopen --iface vcan0 simulate tests/vcan/test-device.eds`, another process) over the
guest's real SocketCAN bus: boot-up, expedited, segmented and block upload and download, abort
codes, NMT start seen in the heartbeat.

usage (inside the rig): remote_vs_simulator.py CANOPEN_BINARY
run-all passes the `canopen` binary built on the host."""

import os
import subprocess
import sys
import time

import canopen
from canopen.sdo import SdoAbortedError

HERE = os.path.dirname(os.path.abspath(__file__))
EDS = os.path.join(HERE, "test-device.eds")
NODE_ID = 0x45


def check(label, got, want):
    if got != want:
        raise AssertionError(f"{label}: got {got!r}, want {want!r}")
    shown = got if not isinstance(got, (bytes, str)) or len(got) <= 48 else f"{len(got)} bytes/chars, equal"
    print(f"ok   {label}: {shown!r}", flush=True)


def expect_abort(label, code, action):
    try:
        action()
    except SdoAbortedError as e:
        check(label, hex(e.code), hex(code))
    else:
        raise AssertionError(f"{label}: no abort")


def main():
    binary = sys.argv[1]
    channel = os.environ.get("CANOPEN_VCAN_IFACE", "vcan0")
    network = canopen.Network()
    network.connect(interface="socketcan", channel=channel)
    node = canopen.RemoteNode(NODE_ID, EDS)
    network.add_node(node)
    node.sdo.RESPONSE_TIMEOUT = 5.0
    bootups = []
    node.nmt.add_heartbeat_callback(lambda state: bootups.append(state) if state == 0 else None)

    sim = subprocess.Popen(
        [binary, "--iface", channel, "simulate", EDS, "--node-id", str(NODE_ID)],
        stdin=subprocess.DEVNULL)
    try:
        t0 = time.monotonic()
        node.nmt.wait_for_bootup(60)
        print(f"simulator booted after {time.monotonic() - t0:.1f}s", flush=True)
        check("NMT state from the heartbeat", node.nmt.wait_for_heartbeat(10), "PRE-OPERATIONAL")

        sdo = node.sdo
        check("expedited upload 0x1000", sdo[0x1000].raw, 0x00020191)
        check("expedited upload 0x1018:04", sdo[0x1018][4].raw, 0x00C0FFEE)
        check("expedited upload 0x2002:01 INTEGER16", sdo[0x2002][1].raw, -1)
        check("segmented upload 0x1008", sdo[0x1008].raw, "canopen-rs vcan test device")
        sdo[0x2000].raw = 0xCAFEBABE
        check("expedited download, read back 0x2000", sdo[0x2000].raw, 0xCAFEBABE)
        sdo[0x2002][2].raw = -1234
        check("expedited download, read back 0x2002:02", sdo[0x2002][2].raw, -1234)
        text = "python-canopen wrote this, segmented, into the canopen-rs simulator"
        sdo[0x2001].raw = text
        check("segmented download, read back 0x2001", sdo[0x2001].raw, text)

        data = bytes((i * 13 + 7) % 251 for i in range(8192))
        with sdo[0x2001].open("wb", size=len(data), block_transfer=True) as f:
            f.write(data)
        check("block download 8 KiB, segmented read back", sdo.upload(0x2001, 0), data)
        with sdo[0x2001].open("rb", block_transfer=True) as f:
            got = f.read()
        check("block upload 8 KiB", got, data)
        with sdo[0x1008].open("rb", block_transfer=True) as f:
            got = f.read()
        check("block upload of a short object", got, b"canopen-rs vcan test device")

        expect_abort("abort for a missing object", 0x06020000, lambda: sdo.upload(0x5FFF, 0))
        expect_abort("abort for a missing sub-index", 0x06090011, lambda: sdo.upload(0x1018, 9))
        expect_abort("abort for writing a read-only object", 0x06010002,
                     lambda: sdo.download(0x1000, 0, b"\x00\x00\x00\x00"))

        node.nmt.state = "OPERATIONAL"
        deadline = time.monotonic() + 10
        state = None
        while state != "OPERATIONAL" and time.monotonic() < deadline:
            state = node.nmt.wait_for_heartbeat(10)
        check("NMT start seen in the heartbeat", state, "OPERATIONAL")
        check("boot-up message seen", bootups[:1], [0])
    finally:
        sim.terminate()
        try:
            sim.wait(10)
        except subprocess.TimeoutExpired:
            sim.kill()
        network.disconnect()
    print("python-canopen RemoteNode and the canopen-rs simulator interoperate over vcan0", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
