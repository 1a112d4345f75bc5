"""python-can as the peer of the CAN FD interop test (tests/main/fd_python.rs).

Joins python-can's udp_multicast bus (CAN FD enabled), prints the first CAN FD frame it
receives as python-can decoded it, then sends one CAN FD frame of its own.

Arguments: GROUP PORT. Protocol on stdout: READY, "GOT id is_fd brs esi hexdata", SENT.
"""

import sys

import can

group, port = sys.argv[1], int(sys.argv[2])
bus = can.Bus(interface="udp_multicast", channel=group, port=port, fd=True)
print("READY", flush=True)
while True:
    m = bus.recv(timeout=20)
    if m is None:
        print("TIMEOUT", flush=True)
        sys.exit(1)
    if m.is_fd:
        break
print(
    "GOT %x %d %d %d %s"
    % (
        m.arbitration_id,
        m.is_fd,
        m.bitrate_switch,
        m.error_state_indicator,
        bytes(m.data).hex(),
    ),
    flush=True,
)
bus.send(
    can.Message(
        arbitration_id=0x5A5,
        is_extended_id=False,
        is_fd=True,
        bitrate_switch=True,
        data=bytes(range(20)),
    )
)
print("SENT", flush=True)
bus.shutdown()
