"""Interop: this project's CiA 309-3 gateway (`canopen gateway --iface vcan0`) in front of
python-canopen's LocalNode (built from tests/vcan/test-device.eds, served by this process) over
the guest's real SocketCAN bus, driven by plain Unix sockets (no CANopen library on the client
side; the guest has no network interface but vcan0, so the TCP listener is tested on the host): typed SDO reads (expedited, segmented, block request answered by the protocol switch),
writes checked on the LocalNode's side, an abort, NMT seen by the LocalNode, boot-up and EMCY
event lines, and four connections pipelining reads at once.

usage (inside the rig): gateway_vs_local_node.py CANOPEN_BINARY"""

import os
import socket
import subprocess
import sys
import threading
import time

import canopen

HERE = os.path.dirname(os.path.abspath(__file__))
EDS = os.path.join(HERE, "test-device.eds")
NODE_ID = 0x46


def check(label, got, want):
    if got != want:
        raise AssertionError(f"{label}: got {got!r}, want {want!r}")
    print(f"ok   {label}: {got!r}", flush=True)


class Connection:
    def __init__(self, path):
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.sock.settimeout(30)
        self.sock.connect(path)
        self.buf = b""

    def line(self):
        while b"\r\n" not in self.buf:
            data = self.sock.recv(4096)
            if not data:
                raise AssertionError("the gateway closed the connection")
            self.buf += data
        line, self.buf = self.buf.split(b"\r\n", 1)
        return line.decode()

    def ask(self, request):
        self.sock.sendall((request + "\r\n").encode())
        return self.line()


def main():
    binary = sys.argv[1]
    channel = os.environ.get("CANOPEN_VCAN_IFACE", "vcan0")
    network = canopen.Network()
    network.connect(interface="socketcan", channel=channel)
    local = canopen.LocalNode(NODE_ID, EDS)
    network.add_node(local)
    local.nmt.state = "INITIALISING"
    local.nmt.state = "PRE-OPERATIONAL"

    path = f"/tmp/canopen-gateway-{os.getpid()}.sock"
    gw = subprocess.Popen(
        [binary, "--iface", channel, "--eds", f"{NODE_ID}={EDS}", "gateway", "--listen", f"unix:{path}",
         "--sdo-timeout", "2000"],
        stderr=subprocess.PIPE, text=True)
    try:
        first = gw.stderr.readline().strip()
        if first != f"canopen gateway: listening on unix:{path}":
            raise AssertionError(f"unexpected gateway output: {first!r}")
        port = path
        c = Connection(port)
        n = NODE_ID
        check("read 0x1000 u32 (expedited)", c.ask(f"[1] {n} r 0x1000 0 u32"), f"[1] {0x00020191}")
        check("read 0x1018:02 x32", c.ask(f"[2] {n} r 0x1018 2 x32"), "[2] 0x00000042")
        check("read 0x2002:03 i16", c.ask(f"[3] {n} r 0x2002 3 i16"), "[3] -32768")
        check("read 0x1008 vs (segmented)", c.ask(f"[4] {n} r 0x1008 0 vs"),
              '[4] "canopen-rs vcan test device"')
        check("set sdo_block 1", c.ask("[5] set sdo_block 1"), "[5] OK")
        check("block read 0x1008 (server switches to a plain upload)", c.ask(f"[6] {n} r 0x1008 0"),
              '[6] "canopen-rs vcan test device"')
        check("set sdo_block 0", c.ask("[7] set sdo_block 0"), "[7] OK")
        check("write 0x2000 u32", c.ask(f"[8] {n} w 0x2000 0 u32 0xCAFEBABE"), "[8] OK")
        check("the LocalNode has 0x2000", local.sdo[0x2000].raw, 0xCAFEBABE)
        text = 'written "through" the gateway, segmented'
        quoted = text.replace('"', '""')
        check("write 0x2001 vs (segmented)", c.ask(f'[9] {n} w 0x2001 0 vs "{quoted}"'), "[9] OK")
        check("the LocalNode has 0x2001", local.sdo[0x2001].raw, text)
        check("read a missing object", c.ask(f"[10] {n} r 0x5FFF 0 u32"), "[10] ERROR:0x06020000")
        check("an unknown command", c.ask(f"[11] {n} frobnicate"), "[11] ERROR:100")
        check("read 0x1008 as os (base64)", c.ask(f"[12] {n} r 0x1008 0 os"),
              "[12] Y2Fub3Blbi1ycyB2Y2FuIHRlc3QgZGV2aWNl")

        check("nmt start", c.ask(f"[13] {n} start"), "[13] OK")
        deadline = time.monotonic() + 10
        while local.nmt.state != "OPERATIONAL" and time.monotonic() < deadline:
            time.sleep(0.05)
        check("nmt start seen by the LocalNode", local.nmt.state, "OPERATIONAL")
        check("nmt preop", c.ask(f"[14] {n} preop"), "[14] OK")
        deadline = time.monotonic() + 10
        while local.nmt.state != "PRE-OPERATIONAL" and time.monotonic() < deadline:
            time.sleep(0.05)
        check("nmt preop seen by the LocalNode", local.nmt.state, "PRE-OPERATIONAL")

        # Event lines: boot-up and EMCY from the LocalNode.
        check("events on", c.ask("[15] _events 1"), "[15] OK")
        local.nmt.send_command(0x82)  # reset communication: boot-up message
        check("boot-up event line", c.line(), f"1 {n} BOOT_UP")
        # python-canopen's heartbeat task repeats the state byte it had (0: boot-up) until the
        # state changes: more boot-up lines may come before the EMCY line.
        local.nmt.send_command(0x80)
        local.emcy.send(0x8130, 0x11, b"\x01\x02\x03\x04\x05")
        line = c.line()
        while line == f"1 {n} BOOT_UP":
            line = c.line()
        check("EMCY event line", line, f"1 {n} EMCY 8130 11 1 2 3 4 5")
        c.sock.sendall(b"[16] _events 0\r\n")
        line = c.line()
        while not line.startswith("["):
            line = c.line()
        check("events off", line, "[16] OK")

        # Four connections, each pipelining 25 reads; every reply by its sequence number.
        errors = []

        def client(k):
            try:
                cc = Connection(port)
                reqs = "".join(f"[{k * 100 + i}] {n} r 0x2002 {1 + i % 3} i16\r\n" for i in range(25))
                cc.sock.sendall(reqs.encode())
                want = {f"[{k * 100 + i}] {[-1, 300, -32768][i % 3]}" for i in range(25)}
                got = {cc.line() for _ in range(25)}
                if got != want:
                    errors.append(f"client {k}: {sorted(got ^ want)}")
            except Exception as e:  # noqa: BLE001
                errors.append(f"client {k}: {e!r}")

        threads = [threading.Thread(target=client, args=(k,)) for k in range(4)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        check("four pipelining connections, every reply right", errors, [])
    finally:
        gw.kill()
        gw.wait()
        if os.path.exists(path):
            os.unlink(path)
        network.disconnect()
    print("the canopen-rs gateway and python-canopen's LocalNode interoperate over vcan0", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
