"""Interop: this project's `canopen` command line as the client of python-canopen's LocalNode
(built from tests/vcan/test-device.eds, served by this process) over the guest's real SocketCAN
bus: SDO reads (expedited, segmented, block request answered by the protocol switch), writes
checked on the LocalNode's side, abort reporting, NMT commands seen by the LocalNode, scan, and
TPDO frames in the CLI's monitor.

usage (inside the rig): cli_vs_local_node.py CANOPEN_BINARY"""

import os
import subprocess
import sys
import time

import canopen

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from canopen_server import start_tpdo1  # noqa: E402

EDS = os.path.join(HERE, "test-device.eds")
NODE_ID = 0x46


def check(label, got, want):
    if got != want:
        raise AssertionError(f"{label}: got {got!r}, want {want!r}")
    print(f"ok   {label}: {got!r}", flush=True)


def main():
    binary = sys.argv[1]
    channel = os.environ.get("CANOPEN_VCAN_IFACE", "vcan0")
    network = canopen.Network()
    network.connect(interface="socketcan", channel=channel)
    local = canopen.LocalNode(NODE_ID, EDS)
    network.add_node(local)
    local.nmt.state = "INITIALISING"
    local.nmt.state = "PRE-OPERATIONAL"

    def cli(*args, ok=True):
        cmd = [binary, "--iface", channel, "--eds", f"{NODE_ID}={EDS}", *args]
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
        if ok and r.returncode != 0:
            raise AssertionError(f"{' '.join(args)}: exit {r.returncode}\n{r.stdout}{r.stderr}")
        return r

    try:
        n = str(NODE_ID)
        check("sdo read 0x1000 (expedited)", cli("sdo", "read", n, "0x1000", "0").stdout.strip(), str(0x00020191))
        check("sdo read 0x1018:02", cli("sdo", "read", n, "0x1018", "2").stdout.strip(), str(0x42))
        check("sdo read 0x2002:03 INTEGER16", cli("sdo", "read", n, "0x2002", "3").stdout.strip(), "-32768")
        check("sdo read 0x1008 (segmented)", cli("sdo", "read", n, "0x1008", "0").stdout.strip(),
              "canopen-rs vcan test device")
        check("sdo read --block 0x1008 (server switches to a plain upload)",
              cli("sdo", "read", "--block", n, "0x1008", "0").stdout.strip(), "canopen-rs vcan test device")

        cli("sdo", "write", n, "0x2000", "0", "0xCAFEBABE")
        check("sdo write 0x2000 seen by the LocalNode", local.sdo[0x2000].raw, 0xCAFEBABE)
        text = "the canopen-rs CLI wrote this, segmented"
        cli("sdo", "write", n, "0x2001", "0", text)
        check("sdo write 0x2001 (segmented) seen by the LocalNode", local.sdo[0x2001].raw, text)
        check("sdo read back 0x2001", cli("sdo", "read", n, "0x2001", "0").stdout.strip(), text)

        r = cli("sdo", "read", n, "0x5FFF", "0", ok=False)
        check("sdo read of a missing object fails", r.returncode != 0, True)
        check("the error names the abort code", "0x06020000" in r.stderr, True)
        print(f"     ({r.stderr.strip()})", flush=True)

        cli("nmt", "start", n)
        deadline = time.monotonic() + 10
        while local.nmt.state != "OPERATIONAL" and time.monotonic() < deadline:
            time.sleep(0.05)
        check("nmt start seen by the LocalNode", local.nmt.state, "OPERATIONAL")
        cli("nmt", "preop", n)
        deadline = time.monotonic() + 10
        while local.nmt.state != "PRE-OPERATIONAL" and time.monotonic() < deadline:
            time.sleep(0.05)
        check("nmt preop seen by the LocalNode", local.nmt.state, "PRE-OPERATIONAL")

        scan = cli("scan").stdout
        print(scan, end="", flush=True)
        check("scan lists the LocalNode", any(line.split()[:2] == [n, str(0xABC)] for line in scan.splitlines()), True)

        # TPDO1 (0x2000 mapped) every 50 ms: the CLI's monitor shows the frames, decoded with
        # the EDS; a value changed on the LocalNode shows in the following ones.
        start_tpdo1(local, 50)

        def monitored_values():
            mon = cli("monitor", "--duration", "1.5").stdout
            lines = [line for line in mon.splitlines() if f"TPDO1 node {NODE_ID}:" in line]
            print("\n".join(lines[:3]), flush=True)
            return [line.split("Test value = ", 1)[-1].strip() for line in lines]

        values = monitored_values()
        check("monitor shows at least 3 TPDO1 of the LocalNode", len(values) >= 3, True)
        check("monitor decodes 0x2000 in each TPDO1", set(values), {str(0xCAFEBABE)})
        local.sdo[0x2000].raw = 0x0BADF00D
        values = monitored_values()
        check("monitor shows at least 3 TPDO1 after the change", len(values) >= 3, True)
        check("monitor decodes the changed 0x2000", set(values), {str(0x0BADF00D)})
    finally:
        network.disconnect()
    print("the canopen-rs CLI and python-canopen's LocalNode interoperate over vcan0", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
