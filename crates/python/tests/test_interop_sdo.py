"""canola's SDO client against python-canopen's SDO server, frame by frame.

python-canopen's `LocalNode` serves SDO on python-can's `udp_multicast` bus; canola joins the
same multicast group with its `udp:` bus spec (the format is python-can's), and a third
python-can bus records every frame. Each transfer is checked against the CiA 301 frame sequence
(the byte traces of python-canopen's own SDO tests: expedited, segmented, and the block
requests its server answers with a plain upload or an abort).

python-can sends with `hop_limit=0` (TTL 0): the kernel loops its frames back to this machine
and puts nothing on the wire. Skipped when this machine has no multicast route.
"""

from __future__ import annotations

import os
import time
from typing import Any, Iterator

import pytest

import canola
from conftest import EDS

can: Any = pytest.importorskip("can")
canopen: Any = pytest.importorskip("canopen")

NODE = 7


class Bridge:
    """python-canopen's LocalNode, canola's node and a recorder, on one multicast group."""

    def __init__(self) -> None:
        group = "239.74.163.32"
        port = 20000 + (os.getpid() * 7) % 9000
        self.pnet = canopen.Network()
        self.pnet.connect(interface="udp_multicast", channel=group, port=port, hop_limit=0)
        self.local = canopen.LocalNode(NODE, str(EDS))
        self.pnet.add_node(self.local)
        self.tap = can.Bus(interface="udp_multicast", channel=group, port=port, hop_limit=0)
        self.reader = can.BufferedReader()
        self.notifier = can.Notifier(self.tap, [self.reader])
        self.net = canola.Network.open(f"udp:{group}:{port}")
        self.node = self.net.add_node(NODE, str(EDS))

    def frames(self) -> list[str]:
        """The SDO frames of node 7 seen since the last call, as `ID#DATA` (the heartbeat
        python-canopen's LocalNode starts when 0x1017 is written is left out)."""
        time.sleep(0.1)
        out = []
        while (m := self.reader.get_message(timeout=0)) is not None:
            if m.arbitration_id in (0x580 + NODE, 0x600 + NODE):
                out.append(f"{m.arbitration_id:03X}#{bytes(m.data).hex().upper()}")
        return out

    def close(self) -> None:
        self.net.disconnect()
        self.notifier.stop()
        self.tap.shutdown()
        self.pnet.disconnect()


@pytest.fixture(scope="module")
def shared_bridge() -> Iterator[Bridge]:
    """One bridge for the module (setting one up and closing it takes about two seconds)."""
    try:
        b = Bridge()
    except (OSError, canola.NetworkError, can.CanError) as e:
        pytest.skip(f"no multicast on this machine: {e}")
    try:
        yield b
    finally:
        b.close()


@pytest.fixture
def bridge(shared_bridge: Bridge) -> Bridge:
    """The bridge, no frame recorded yet."""
    shared_bridge.frames()
    return shared_bridge


def test_expedited_upload(bridge: Bridge) -> None:
    assert bridge.node.sdo[0x1017].raw == 500
    assert bridge.frames() == ["607#4017100000000000", "587#4B171000F4010000"]


def test_expedited_download(bridge: Bridge) -> None:
    bridge.node.sdo[0x1017].raw = 1000
    assert bridge.frames() == ["607#2B171000E8030000", "587#6017100000000000"]
    assert bridge.local.sdo[0x1017].raw == 1000


def test_segmented_upload(bridge: Bridge) -> None:
    assert bridge.node.sdo[0x1008].raw == "Buerkert generic device"
    text = b"Buerkert generic device"
    assert bridge.frames() == [
        "607#4008100000000000",
        "587#4108100017000000",  # size indicated: 23 bytes
        "607#6000000000000000",
        "587#00" + text[0:7].hex().upper(),
        "607#7000000000000000",
        "587#10" + text[7:14].hex().upper(),
        "607#6000000000000000",
        "587#00" + text[14:21].hex().upper(),
        "607#7000000000000000",
        # Last segment, toggle 1, 5 bytes unused: 0x1B.
        "587#1B" + text[21:23].hex().upper() + "0000000000",
    ]


def test_segmented_download(bridge: Bridge) -> None:
    text = b"pump room 3, rack B"  # 19 bytes
    bridge.node.sdo[0x2002][3].raw = text.decode()
    assert bridge.frames() == [
        "607#2102200313000000",  # size indicated: 19 bytes
        "587#6002200300000000",
        "607#00" + text[0:7].hex().upper(),
        "587#2000000000000000",
        "607#10" + text[7:14].hex().upper(),
        "587#3000000000000000",
        # Last segment, toggle 0, 2 bytes unused: 0x05.
        "607#05" + text[14:19].hex().upper() + "0000",
        "587#2000000000000000",
    ]
    assert bridge.local.sdo[0x2002][3].raw == text.decode()


def test_block_upload_answered_as_a_plain_upload(bridge: Bridge) -> None:
    # python-canopen's server answers a block upload request with the segmented upload's
    # initiate response (CiA 301 allows it); the client goes on segmented.
    with bridge.node.sdo[0x1008].open("rb", block_transfer=True) as f:
        assert f.read() == b"Buerkert generic device"
    frames = bridge.frames()
    assert frames[0][:12] == "607#A4081000", frames
    assert frames[1] == "587#4108100017000000", frames
    assert frames[-1][:6] == "587#1B", frames


def test_block_download_is_refused_with_its_abort(bridge: Bridge) -> None:
    with pytest.raises(canola.SdoAbortedError) as err:
        with bridge.node.sdo[0x2002][3].open("wb", block_transfer=True) as f:
            f.write(b"x" * 40)
    assert err.value.code == 0x05040001
    frames = bridge.frames()
    assert frames[0][:12] == "607#C6022003", frames
    assert frames[1] == "587#8002200301000405", frames


def test_python_canopen_reads_and_writes_canola_s_simulator() -> None:
    """The other way round: `SimDevice.serve` puts canola's simulator on the multicast bus,
    and python-canopen's RemoteNode is its SDO client (expedited and segmented)."""
    group = "239.74.163.35"
    port = 20000 + (os.getpid() * 11) % 9000
    try:
        service = canola.SimDevice.from_eds(str(EDS), 5).serve(f"udp:{group}:{port}")
    except canola.NetworkError as e:
        pytest.skip(f"no multicast on this machine: {e}")
    with service:
        assert service.running
        pnet = canopen.Network()
        try:
            pnet.connect(interface="udp_multicast", channel=group, port=port, hop_limit=0)
        except (OSError, can.CanError) as e:
            pytest.skip(f"no multicast on this machine: {e}")
        try:
            node = pnet.add_node(5, str(EDS))
            assert node.sdo[0x1017].raw == 500
            assert node.sdo[0x1008].raw == "Buerkert generic device"
            node.sdo[0x2002][3].raw = "written by python-canopen"
            assert node.sdo[0x2002][3].raw == "written by python-canopen"
            with pytest.raises(canopen.SdoAbortedError) as err:
                node.sdo[0x1000].raw = 1
            assert err.value.code == 0x06010002
        finally:
            pnet.disconnect()
    assert not service.running
    service.stop()  # stopping twice is nothing


def test_a_served_device_is_not_attached_again() -> None:
    device = canola.SimDevice.from_eds(str(EDS), 5)
    canola.MemoryBus().attach(device)
    with pytest.raises(ValueError, match="attached to a bus already"):
        device.serve("udp:239.74.163.36:20999")
