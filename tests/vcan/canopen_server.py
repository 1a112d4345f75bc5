"""A python-canopen LocalNode from tests/vcan/test-device.eds on the real SocketCAN bus: the
device side of canopen_sdo_check.py (and of interop tests that need an independent CANopen
server). Boots (boot-up message, then heartbeats per 0x1017), prints READY and serves until its
standard input closes or says `quit`.

usage: canopen_server.py [NODE_ID] [EDS]"""

import os
import sys

import canopen

HERE = os.path.dirname(os.path.abspath(__file__))


def main():
    node_id = int(sys.argv[1], 0) if len(sys.argv) > 1 else 0x22
    eds = sys.argv[2] if len(sys.argv) > 2 else os.path.join(HERE, "test-device.eds")
    channel = os.environ.get("CANOPEN_VCAN_IFACE", "vcan0")
    network = canopen.Network()
    network.connect(interface="socketcan", channel=channel)
    try:
        node = canopen.LocalNode(node_id, eds)
        network.add_node(node)
        # INITIALISING sends the boot-up message; PRE-OPERATIONAL starts the heartbeat (0x1017).
        node.nmt.state = "INITIALISING"
        node.nmt.state = "PRE-OPERATIONAL"
        print(f"READY node {node_id} on {channel}", flush=True)
        for line in sys.stdin:
            if line.strip() == "quit":
                break
    finally:
        network.disconnect()
    return 0


if __name__ == "__main__":
    sys.exit(main())
