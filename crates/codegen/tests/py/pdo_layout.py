"""python-canopen's view of an EDS's default PDO mappings, for canola-codegen's cross-check.

Usage: pdo_layout.py EDS NODE_ID [tN:HEX ...]

Prints one line per PDO python-canopen reads from the file's defaults,
`t1 COB_ID INDEX:SUB:OFFSET:LENGTH ...` (`r1` for RPDOs, all numbers decimal), then one line per
`tN:HEX` argument, `decoded tN:HEX VALUE ...`, with the raw values python-canopen decodes from
those data bytes in mapping order (booleans as 0/1, floats with repr, bytes in hex).
"""

import sys

import canopen


def main():
    eds, node_id, frames = sys.argv[1], int(sys.argv[2], 0), sys.argv[3:]
    network = canopen.Network()
    node = canopen.RemoteNode(node_id, eds)
    network.add_node(node)
    node.tpdo.read(from_od=True)
    node.rpdo.read(from_od=True)
    for prefix, maps in (("t", node.tpdo), ("r", node.rpdo)):
        for number, pdo in maps.items():
            entries = " ".join(
                f"{v.od.index}:{v.od.subindex}:{v.offset}:{v.length}" for v in pdo.map
            )
            print(f"{prefix}{number} {pdo.cob_id} {entries}".rstrip())
    for arg in frames:
        which, data = arg.split(":")
        pdo = node.tpdo[int(which[1:])]
        pdo.data = bytearray.fromhex(data)
        values = []
        for v in pdo.map:
            raw = v.raw
            if isinstance(raw, bool):
                raw = int(raw)
            if isinstance(raw, (bytes, bytearray)):
                raw = raw.hex()
            values.append(repr(raw) if isinstance(raw, float) else str(raw))
        print(f"decoded {arg} {' '.join(values)}")


main()
