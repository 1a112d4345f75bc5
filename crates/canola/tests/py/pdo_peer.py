"""python-canopen 2.4.1 as the device for the PDO interop test (tests/main/pdo_python.rs).

A LocalNode with the Buerkert EDS on python-can's udp_multicast bus. It consumes its RPDO1 as
python-canopen decodes it (one line per reception) and, on "TPDO" from stdin, reads its own
TPDO1 parameters (as the master saved them into its object dictionary) with python-canopen's
own PDO code, prints them and transmits TPDO1 with a sensor value.

Arguments: GROUP PORT EDS. Protocol on stdout: READY, then lines "RPDO1 v1 v2" and
"TPDO1 ...", "SENT".
"""

import sys

import canopen

group, port, eds = sys.argv[1], int(sys.argv[2]), sys.argv[3]
net = canopen.Network()
net.connect(interface="udp_multicast", channel=group, port=port)
node = canopen.LocalNode(5, eds)
net.add_node(node)
node.rpdo.read(from_od=True)


def on_rpdo(m):
    print("RPDO1 " + " ".join(repr(v.raw) for v in m.map), flush=True)


node.rpdo[1].add_callback(on_rpdo)
print("READY", flush=True)

for line in sys.stdin:
    cmd = line.strip()
    if cmd == "TPDO":
        node.tpdo.read()  # through its own SDO server: what the master wrote
        m = node.tpdo[1]
        entries = ",".join(
            "%04x:%02x/%d" % (v.index, v.subindex, v.length) for v in m.map
        )
        print(
            "TPDO1 cob=0x%x enabled=%s type=%d event=%s map=%s"
            % (m.cob_id, m.enabled, m.trans_type, m.event_timer, entries),
            flush=True,
        )
        for v in m.map:
            if (v.index, v.subindex) == (0x2500, 1):
                v.raw = 21.5
            elif (v.index, v.subindex) == (0x2004, 1):
                v.raw = 3
        m.transmit()
        print("SENT", flush=True)
    elif cmd == "QUIT":
        break
net.disconnect()
