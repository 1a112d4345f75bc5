"""python-can on the guest's real SocketCAN bus: raw frames between two buses and a periodic
(CAN_BCM) send, which python-canopen uses for heartbeats. Runs inside the rig:
`tests/vcan/rig run -- .venv/bin/python tests/vcan/python_can_check.py`."""

import os
import sys
import time

import can

CHANNEL = os.environ.get("CANOPEN_VCAN_IFACE", "vcan0")
WAIT = 10.0


def recv_id(bus, arbitration_id, timeout=WAIT):
    deadline = time.monotonic() + timeout
    while True:
        left = deadline - time.monotonic()
        if left <= 0:
            raise AssertionError(f"no frame 0x{arbitration_id:X} within {timeout}s")
        msg = bus.recv(left)
        if msg is not None and msg.arbitration_id == arbitration_id:
            return msg


def main():
    a = can.Bus(interface="socketcan", channel=CHANNEL)
    b = can.Bus(interface="socketcan", channel=CHANNEL)
    try:
        sent = [
            can.Message(arbitration_id=0x601, data=[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0], is_extended_id=False),
            can.Message(arbitration_id=0x1ABCDE01, data=[1, 2, 3], is_extended_id=True),
            can.Message(arbitration_id=0x705, is_remote_frame=True, dlc=1, is_extended_id=False),
        ]
        for msg in sent:
            a.send(msg)
        for want in sent:
            got = b.recv(WAIT)
            assert got is not None, "frame lost"
            assert got.arbitration_id == want.arbitration_id, got
            assert got.is_extended_id == want.is_extended_id, got
            assert got.is_remote_frame == want.is_remote_frame, got
            assert got.dlc == want.dlc, got
            if not want.is_remote_frame:
                assert bytes(got.data) == bytes(want.data), got
        print("python-can: standard, extended and remote frames crossed between two buses")

        # A periodic send goes through the kernel's broadcast manager (CAN_BCM).
        task = a.send_periodic(can.Message(arbitration_id=0x77F, data=[0x7F], is_extended_id=False), 0.02)
        try:
            stamps = [recv_id(b, 0x77F).timestamp for _ in range(5)]
        finally:
            task.stop()
        print(f"python-can: 5 periodic (CAN_BCM) frames received, mean gap {(stamps[-1] - stamps[0]) / 4 * 1000:.1f} ms")
    finally:
        a.shutdown()
        b.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
