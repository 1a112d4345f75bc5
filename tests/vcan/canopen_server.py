"""A python-canopen LocalNode from tests/vcan/test-device.eds on the real SocketCAN bus: the
device side of canopen_sdo_check.py (and of interop tests that need an independent CANopen
server). Boots (boot-up message, then heartbeats per 0x1017), prints READY and serves until its
standard input closes or says `quit`.

With --tpdo-ms N it also sends TPDO1 (configured from the EDS: 0x1800/0x1A00, 0x2000 mapped)
every N ms; an SDO write to 0x2000 changes the value the following PDOs carry.

With --rpdo it also applies RPDO1 (0x1400/0x1600 from the EDS: 0x2003 and 0x2002:02) to its
dictionary, so an SDO read shows what the last RPDO carried, and prints `RPDO1 <hex>`.

usage: canopen_server.py [--tpdo-ms N] [--rpdo] [NODE_ID] [EDS]"""

import os
import sys

import canopen

HERE = os.path.dirname(os.path.abspath(__file__))


def start_tpdo1(node, period_ms):
    node.tpdo.read(from_od=True)
    tpdo = node.tpdo[1]
    var = tpdo[0]
    var.raw = node.sdo[var.index][var.subindex].raw if var.subindex else node.sdo[var.index].raw

    def on_write(index, subindex, od, data):
        if index == var.index and subindex == var.subindex:
            var.set_data(data)
            tpdo.update()

    node.add_write_callback(on_write)
    tpdo.start(period_ms / 1000.0)


def apply_rpdo1(node):
    node.rpdo.read(from_od=True)
    rpdo = node.rpdo[1]

    def on_rpdo(pdo_map):
        for var in pdo_map:
            node.set_data(var.index, var.subindex, var.get_data())
        print(f"RPDO1 {bytes(pdo_map.data).hex()}", flush=True)

    rpdo.add_callback(on_rpdo)


def main():
    args = sys.argv[1:]
    tpdo_ms = 0
    rpdo = False
    while args[:1] in (["--tpdo-ms"], ["--rpdo"]):
        if args[0] == "--rpdo":
            rpdo = True
            args = args[1:]
        else:
            tpdo_ms = int(args[1])
            args = args[2:]
    node_id = int(args[0], 0) if len(args) > 0 else 0x22
    eds = args[1] if len(args) > 1 else os.path.join(HERE, "test-device.eds")
    channel = os.environ.get("CANOPEN_VCAN_IFACE", "vcan0")
    network = canopen.Network()
    network.connect(interface="socketcan", channel=channel)
    try:
        node = canopen.LocalNode(node_id, eds)
        network.add_node(node)
        # INITIALISING sends the boot-up message; PRE-OPERATIONAL starts the heartbeat (0x1017).
        node.nmt.state = "INITIALISING"
        node.nmt.state = "PRE-OPERATIONAL"
        if tpdo_ms:
            start_tpdo1(node, tpdo_ms)
        if rpdo:
            apply_rpdo1(node)
        print(f"READY node {node_id} on {channel}", flush=True)
        for line in sys.stdin:
            if line.strip() == "quit":
                break
    finally:
        network.disconnect()
    return 0


if __name__ == "__main__":
    sys.exit(main())
