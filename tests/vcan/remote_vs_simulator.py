"""Interop: python-canopen's RemoteNode (this process) as the client of this project's device
simulator (`canopen --iface vcan0 simulate tests/vcan/test-device.eds`, another process) over the
guest's real SocketCAN bus: boot-up, expedited, segmented and block upload and download, abort
codes, NMT start seen in the heartbeat; PDOs: the TPDO1 and RPDO1 configuration read from the
simulator by SDO (`node.tpdo.read()`, `node.rpdo.read()`), TPDO1 remapped by python-canopen
(`PdoMap.save()`: disable, clear, map, count, enable) and read back, TPDO1 received in Operational
with values equal to the SDO reads of the mapped objects (also after an SDO write changes one),
and an RPDO from python-canopen applied by the simulator (SDO read back, and seen in the next
TPDO).

With `--slcan`, the simulator runs on this project's slcan transport (`--iface slcan:PTY`) and
python-canopen on the Linux kernel's slcan driver (`slcan0`): two pseudo-terminal pairs joined by
a byte pump here, the kernel driver attached to one by can-utils' `slcand`, the simulator on the
other. The same checks then cover SDO in all three modes (block both ways included, with
python-canopen's block client), NMT and PDOs through the slcan transport against two
implementations this project did not write.

usage (inside the rig): remote_vs_simulator.py CANOPEN_BINARY [--slcan]
run-all passes the `canopen` binary built on the host."""

import os
import select
import subprocess
import sys
import threading
import time
import tty

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


def mapped(pdo_map):
    """(index, sub-index, bits) of each mapped object."""
    return [(v.index, v.subindex, v.length) for v in pdo_map.map]


def configure_pdos(node):
    """In Pre-operational: reads TPDO1 and RPDO1 from the simulator by SDO, remaps TPDO1 to carry
    0x2000 and 0x2002:02, and reads it back. Returns (TPDO1, RPDO1)."""
    sdo = node.sdo
    node.tpdo.read()
    tpdo = node.tpdo[1]
    check("TPDO1 COB-ID read by SDO", hex(tpdo.cob_id), hex(0x180 + NODE_ID))
    check("TPDO1 enabled", tpdo.enabled, True)
    check("TPDO1 transmission type", tpdo.trans_type, 254)
    check("TPDO1 event timer (ms)", tpdo.event_timer, 100)
    check("TPDO1 mapping read by SDO", mapped(tpdo), [(0x2000, 0, 32)])
    node.rpdo.read()
    rpdo = node.rpdo[1]
    check("RPDO1 COB-ID read by SDO", hex(rpdo.cob_id), hex(0x200 + NODE_ID))
    check("RPDO1 mapping read by SDO", mapped(rpdo), [(0x2003, 0, 32), (0x2002, 2, 16)])

    # Remap TPDO1 the CiA 301 way (python-canopen's save(): COB-ID invalid, count 0, entries,
    # count, COB-ID valid), all by SDO to the simulator.
    tpdo.clear()
    tpdo.add_variable(0x2000)
    tpdo.add_variable(0x2002, 2)
    tpdo.save()
    check("TPDO1 remapped: 0x1A00:00 read back", sdo[0x1A00][0].raw, 2)
    check("TPDO1 remapped: 0x1A00:02 read back", hex(sdo[0x1A00][2].raw), hex(0x20020210))
    check("TPDO1 enabled again: 0x1800:01", hex(sdo[0x1800][1].raw), hex(0x180 + NODE_ID))
    node.tpdo.read()
    tpdo = node.tpdo[1]
    check("TPDO1 mapping read again by SDO", mapped(tpdo), [(0x2000, 0, 32), (0x2002, 2, 16)])
    return tpdo, rpdo


def next_tpdo(tpdo, label):
    """Waits for the next reception of `tpdo`; returns its mapped values."""
    if tpdo.wait_for_reception(5) is None:
        raise AssertionError(f"{label}: no TPDO 0x{tpdo.cob_id:X} within 5 s")
    return [v.raw for v in tpdo.map], bytes(tpdo.data)


def receive_pdos(node, tpdo, rpdo):
    """In Operational: TPDO1 values against SDO reads; an SDO write shows in later TPDOs; an
    RPDO from python-canopen is applied by the simulator."""
    sdo = node.sdo
    want = [sdo[0x2000].raw, sdo[0x2002][2].raw]
    check("values of the mapped objects by SDO", want, [0xCAFEBABE, -1234])
    values, data = next_tpdo(tpdo, "first TPDO1")
    check("TPDO1 data length", len(data), 6)
    check("TPDO1 decoded with the mapping read by SDO", values, want)
    check("TPDO1 bytes", data.hex(), (0xCAFEBABE).to_bytes(4, "little").hex()
          + (-1234).to_bytes(2, "little", signed=True).hex())

    # A new value by SDO: the event timer (100 ms) carries it in a later TPDO.
    sdo[0x2000].raw = 0x0BADF00D
    check("0x2000 read back by SDO", sdo[0x2000].raw, 0x0BADF00D)
    seen = []
    for _ in range(20):
        values, _ = next_tpdo(tpdo, "TPDO1 after the SDO write")
        seen.append(values[0])
        if values[0] == 0x0BADF00D:
            break
    check("TPDO1 carries the value written by SDO", seen[-1], 0x0BADF00D)
    check("TPDO1 values equal the SDO reads", values, [sdo[0x2000].raw, sdo[0x2002][2].raw])

    # RPDO1 from python-canopen: 0x2003 and 0x2002:02 set in the simulator.
    rpdo[0].raw = 0x13572468
    rpdo[1].raw = -321
    check("RPDO1 bytes sent", bytes(rpdo.data).hex(), "68245713" + "bffe")
    rpdo.transmit()
    check("RPDO1 applied: 0x2003 by SDO", hex(sdo[0x2003].raw), hex(0x13572468))
    check("RPDO1 applied: 0x2002:02 by SDO", sdo[0x2002][2].raw, -321)
    seen = []
    for _ in range(20):
        values, _ = next_tpdo(tpdo, "TPDO1 after the RPDO")
        seen.append(values[1])
        if values[1] == -321:
            break
    check("TPDO1 carries 0x2002:02 as set by the RPDO", seen[-1], -321)


class PtyBridge:
    """Two pseudo-terminal pairs whose masters a thread joins byte for byte: each slave has a
    path (`a`, `b`), so one program can open each side as a serial port."""

    def __init__(self):
        self.fds = []
        paths = []
        for _ in range(2):
            master, slave = os.openpty()
            tty.setraw(slave)
            self.fds += [master, slave]
            paths.append(os.ttyname(slave))
        self.a, self.b = paths
        self.stopped = False
        self.thread = threading.Thread(target=self.pump, daemon=True)
        self.thread.start()

    def pump(self):
        ma, mb = self.fds[0], self.fds[2]
        other = {ma: mb, mb: ma}
        while not self.stopped:
            ready, _, _ = select.select([ma, mb], [], [], 0.2)
            for fd in ready:
                try:
                    data = os.read(fd, 4096)
                except OSError:
                    continue  # the slave side is closed for now (the program reopens it)
                view = memoryview(data)
                while view:
                    view = view[os.write(other[fd], view):]

    def close(self):
        self.stopped = True
        self.thread.join(2)
        for fd in self.fds:
            os.close(fd)


def attach_slcan0(path):
    """The kernel's slcan driver on the tty `path`, as the interface slcan0 (up)."""
    slcand = subprocess.Popen(["slcand", "-o", "-c", "-s6", "-F", path, "slcan0"])
    deadline = time.monotonic() + 20
    while not os.path.exists("/sys/class/net/slcan0"):
        if time.monotonic() > deadline:
            raise AssertionError("slcand did not create slcan0")
        time.sleep(0.05)
    # slcan interfaces come with a transmit queue of 10 frames: python-canopen's block download
    # sends a sub-block of up to 127 segments at once, which such a queue refuses (ENOBUFS).
    subprocess.run(["ip", "link", "set", "slcan0", "txqueuelen", "1000", "up"], check=True)
    return slcand


def main():
    binary = sys.argv[1]
    channel = os.environ.get("CANOPEN_VCAN_IFACE", "vcan0")
    sim_iface = channel
    bridge = slcand = None
    if "--slcan" in sys.argv[2:]:
        bridge = PtyBridge()
        slcand = attach_slcan0(bridge.a)
        channel = "slcan0"
        sim_iface = f"slcan:{bridge.b}@500k"
        print(f"python-canopen on slcan0 (kernel driver on {bridge.a}), "
              f"the simulator on {sim_iface}", flush=True)
    network = canopen.Network()
    network.connect(interface="socketcan", channel=channel)
    node = canopen.RemoteNode(NODE_ID, EDS)
    network.add_node(node)
    node.sdo.RESPONSE_TIMEOUT = 5.0
    bootups = []
    node.nmt.add_heartbeat_callback(lambda state: bootups.append(state) if state == 0 else None)

    sim = subprocess.Popen(
        [binary, "--iface", sim_iface, "simulate", EDS, "--node-id", str(NODE_ID)],
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

        tpdo, rpdo = configure_pdos(node)

        node.nmt.state = "OPERATIONAL"
        deadline = time.monotonic() + 10
        state = None
        while state != "OPERATIONAL" and time.monotonic() < deadline:
            state = node.nmt.wait_for_heartbeat(10)
        check("NMT start seen in the heartbeat", state, "OPERATIONAL")
        check("boot-up message seen", bootups[:1], [0])

        receive_pdos(node, tpdo, rpdo)
    finally:
        sim.terminate()
        try:
            sim.wait(10)
        except subprocess.TimeoutExpired:
            sim.kill()
        network.disconnect()
        if slcand is not None:
            slcand.terminate()
            slcand.wait(10)
        if bridge is not None:
            bridge.close()
    print(f"python-canopen RemoteNode and the canopen-rs simulator interoperate over {channel}",
          flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
