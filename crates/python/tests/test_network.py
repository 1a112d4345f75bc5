"""The network's life: connect, open, `with`, disconnect."""

from __future__ import annotations

import pytest

import canola
from conftest import EDS


def test_with_closes_the_network() -> None:
    bus = canola.MemoryBus()
    bus.attach(canola.SimDevice.from_eds(EDS.read_bytes(), 5))
    with canola.Network(bus) as net:
        node = net.add_node(5, str(EDS))
        assert node.sdo[0x1017].raw == 500
    with pytest.raises(canola.NetworkError, match="not connected"):
        node.sdo[0x1017].raw
    with pytest.raises(canola.NetworkError, match="not connected"):
        net.add_node(6, str(EDS))


def test_connect_virtual_joins_the_in_process_bus_of_that_channel() -> None:
    bus = canola.MemoryBus.virtual_channel("test-connect")
    assert bus.realtime
    bus.attach(canola.SimDevice.from_eds(str(EDS), 7))
    net = canola.Network()
    assert net.connect(interface="virtual", channel="test-connect") is net
    try:
        node = net.add_node(7, str(EDS))
        assert node.sdo["Producer heartbeat time"].raw == 500
        # The network runs by itself on a real-time bus: heartbeats arrive without a wait.
        assert node.nmt.wait_for_heartbeat(2) == "PRE-OPERATIONAL"
    finally:
        net.disconnect()


def test_open_names_the_bus_it_could_not_open() -> None:
    with pytest.raises(canola.NetworkError, match="nonexistent0"):
        canola.Network.open("nonexistent0")
    with pytest.raises(canola.NetworkError):
        canola.Network().connect(interface="socketcan", channel="nonexistent0")


def test_unknown_interface_is_refused() -> None:
    with pytest.raises(NotImplementedError, match="pcan"):
        canola.Network().connect(interface="pcan", channel="PCAN_USBBUS1")


def test_a_device_goes_on_one_bus() -> None:
    device = canola.SimDevice.from_eds(str(EDS), 5)
    assert device.id == 5
    canola.MemoryBus().attach(device)
    with pytest.raises(ValueError, match="attached"):
        canola.MemoryBus().attach(device)


def test_bad_input_is_refused_with_python_errors() -> None:
    with pytest.raises(ValueError, match="node-ID 0"):
        canola.SimDevice.from_eds(str(EDS), 0)
    with pytest.raises(FileNotFoundError):
        canola.RemoteNode(5, "/nonexistent/device.eds")
    with pytest.raises(ValueError):
        canola.RemoteNode(5, b"\xff\xfe not an EDS [")
