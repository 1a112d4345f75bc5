"""python-canopen both sides over the guest's real SocketCAN bus: a RemoteNode (this process)
against a LocalNode built from tests/vcan/test-device.eds in a second process
(canopen_server.py). Checks boot-up and heartbeat, expedited and segmented SDO upload and
download, an SDO abort for a missing object, and NMT start seen in the heartbeat.
Runs inside the rig: `tests/vcan/rig run -- .venv/bin/python tests/vcan/canopen_sdo_check.py`."""

import os
import subprocess
import sys
import threading
import time

import canopen
from canopen.sdo import SdoAbortedError

HERE = os.path.dirname(os.path.abspath(__file__))
EDS = os.path.join(HERE, "test-device.eds")
NODE_ID = 0x22
STARTUP = 120.0  # seconds; Python under TCG imports slowly


def check(label, got, want):
    if got != want:
        raise AssertionError(f"{label}: got {got!r}, want {want!r}")
    print(f"ok   {label}: {got!r}", flush=True)


def main():
    channel = os.environ.get("CANOPEN_VCAN_IFACE", "vcan0")
    network = canopen.Network()
    network.connect(interface="socketcan", channel=channel)
    node = canopen.RemoteNode(NODE_ID, EDS)
    network.add_node(node)
    bootups = []
    node.nmt.add_heartbeat_callback(lambda state: bootups.append(state) if state == 0 else None)

    server = subprocess.Popen(
        [sys.executable, "-u", os.path.join(HERE, "canopen_server.py"), hex(NODE_ID), EDS],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    ready = threading.Event()

    def pump():
        for line in server.stdout:
            print(f"server: {line.rstrip()}", flush=True)
            if line.startswith("READY"):
                ready.set()

    threading.Thread(target=pump, daemon=True).start()
    try:
        t0 = time.monotonic()
        if not ready.wait(STARTUP):
            raise AssertionError(f"the LocalNode process was not ready within {STARTUP}s")
        print(f"server ready after {time.monotonic() - t0:.1f}s", flush=True)

        # The boot-up message arrives before READY; heartbeats follow every 100 ms (0x1017).
        check("NMT state from the heartbeat", node.nmt.wait_for_heartbeat(10), "PRE-OPERATIONAL")
        check("boot-up message seen", bootups[:1], [0])

        sdo = node.sdo
        check("expedited upload 0x1000 device type", sdo[0x1000].raw, 0x00020191)
        check("expedited upload 0x1018:01 vendor-ID", sdo[0x1018][1].raw, 0x00000ABC)
        check("expedited upload 0x2002:03 INTEGER16", sdo[0x2002][3].raw, -32768)
        check("segmented upload 0x1008 device name", sdo[0x1008].raw, "canopen-rs vcan test device")
        check("raw segmented upload 0x1008", sdo.upload(0x1008, 0), b"canopen-rs vcan test device")

        sdo[0x2000].raw = 0xCAFEBABE
        check("expedited download then upload 0x2000", sdo[0x2000].raw, 0xCAFEBABE)
        text = "segmented download over the real kernel CAN stack " * 3
        sdo[0x2001].raw = text
        check("segmented download then upload 0x2001", sdo[0x2001].raw, text)
        sdo.download(0x2001, 0, b"abc")
        check("expedited download of 3 bytes to 0x2001", sdo.upload(0x2001, 0), b"abc")

        try:
            sdo.upload(0x5FFF, 0)
        except SdoAbortedError as e:
            check("abort code for a missing object", hex(e.code), hex(0x06020000))
        else:
            raise AssertionError("upload of 0x5FFF did not abort")

        node.nmt.state = "OPERATIONAL"
        deadline = time.monotonic() + 10
        while True:
            state = node.nmt.wait_for_heartbeat(10)
            if state == "OPERATIONAL" or time.monotonic() > deadline:
                break
        check("NMT start seen in the heartbeat", state, "OPERATIONAL")
        check("SDO still served in OPERATIONAL", sdo[0x1018][4].raw, 0x00C0FFEE)
    finally:
        try:
            server.stdin.write("quit\n")
            server.stdin.close()
            server.wait(30)
        except Exception:
            server.kill()
        network.disconnect()
    check("LocalNode process exit status", server.returncode, 0)
    print("python-canopen: RemoteNode and LocalNode interoperate over vcan0", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
