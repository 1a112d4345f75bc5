"""EMCY: node.emcy's lists, callbacks and waits, for emergencies sent on the in-memory bus by
a second network (python-canopen's `send_message`), as a device would send them."""

from __future__ import annotations

from typing import Iterator

import pytest

import canola


@pytest.fixture
def device(bus: canola.MemoryBus) -> Iterator[canola.Network]:
    """A second network on the bus, standing in for node 5's EMCY producer."""
    with canola.Network(bus) as other:
        yield other


def emcy(device: canola.Network, code: int, register: int = 0, data: bytes = b"") -> None:
    payload = code.to_bytes(2, "little") + bytes([register]) + data.ljust(5, b"\0")
    device.send_message(0x85, payload)


def test_emcys_are_logged_and_active_until_an_error_reset(
    node: canola.RemoteNode, device: canola.Network
) -> None:
    emcy(device, 0x5000, 0x01, b"\x01\x02\x03\x04\x05")
    err = node.emcy.wait(timeout=1.0)
    assert err is not None
    assert isinstance(err, canola.EmcyError) and isinstance(err, Exception)
    assert (err.code, err.register, err.data) == (0x5000, 0x01, b"\x01\x02\x03\x04\x05")
    assert err.get_desc() != "" and str(err).startswith("Code 0x5000")
    assert [e.code for e in node.emcy.active] == [0x5000]
    emcy(device, 0x0000)
    assert node.emcy.wait(timeout=1.0) is not None
    assert node.emcy.active == []
    assert [e.code for e in node.emcy.log] == [0x5000, 0x0000]
    node.emcy.reset()
    assert node.emcy.log == []


def test_wait_for_a_code_and_timeout(node: canola.RemoteNode, device: canola.Network) -> None:
    assert node.emcy.wait(timeout=0.2) is None
    emcy(device, 0x1000)
    emcy(device, 0x8130)
    err = node.emcy.wait(0x8130, timeout=1.0)
    assert err is not None and err.code == 0x8130
    # Another node's EMCY is not this node's.
    device.send_message(0x86, bytes(8))
    assert node.emcy.wait(timeout=0.2) is None


def test_callbacks_get_each_emcy(node: canola.RemoteNode, device: canola.Network) -> None:
    got: list[int] = []
    node.emcy.add_callback(lambda e: got.append(e.code))
    emcy(device, 0x2310)
    node.emcy.wait(timeout=1.0)
    assert got == [0x2310]


def test_raising_an_emcy_error_works() -> None:
    with pytest.raises(canola.EmcyError) as info:
        raise canola.EmcyError(0x3210, 4, b"", 0.0, "Voltage")
    assert info.value.get_desc() == "Voltage"


def test_each_node_gets_its_own_emcys(
    network: canola.Network, node: canola.RemoteNode, device: canola.Network
) -> None:
    from conftest import EDS

    other = network.add_node(6, str(EDS))
    device.send_message(0x86, (0x6100).to_bytes(2, "little") + bytes(6))
    emcy(device, 0x4210)
    err = other.emcy.wait(timeout=1.0)
    assert err is not None and err.code == 0x6100
    assert [e.code for e in node.emcy.log] == [0x4210]
    assert [e.code for e in other.emcy.log] == [0x6100]
