"""LSS (network.lss, python-canopen's LssMaster) against an unconfigured simulated device."""

from __future__ import annotations

import pytest

import canola
from conftest import EDS

ADDRESS = (0x78, 0x1234, 1, 42)  # vendor-ID, product code, revision, serial number


@pytest.fixture
def unconfigured(bus: canola.MemoryBus) -> canola.MemoryBus:
    """The bus with, besides node 5, a device without a node-ID."""
    device = canola.SimDevice.unconfigured(str(EDS), ADDRESS)
    assert device.id is None
    bus.attach(device)
    return bus


def test_fast_scan_then_configure_a_node_id(
    unconfigured: canola.MemoryBus, network: canola.Network
) -> None:
    lss = network.lss
    assert lss.send_identify_non_configured_remote_slave()
    found, address = lss.fast_scan()
    assert found and address == list(ADDRESS)
    assert lss.inquire_node_id() == 0xFF
    assert lss.inquire_lss_address(0x5A) == 0x78
    assert lss.inquire_lss_address(0x5D) == 42
    lss.configure_node_id(9)
    lss.send_switch_state_global(lss.WAITING_STATE)
    node = network.add_node(9, str(EDS))
    node.nmt.wait_for_bootup(2.0)
    assert node.sdo[0x1018][1].raw == 0x78
    assert not lss.send_identify_non_configured_remote_slave()


def test_selective_switch_and_identify(
    unconfigured: canola.MemoryBus, network: canola.Network
) -> None:
    lss = network.lss
    assert lss.send_switch_state_selective(*ADDRESS)
    assert lss.inquire_lss_address(0x5B) == 0x1234
    lss.send_switch_state_global(lss.WAITING_STATE)
    assert not lss.send_switch_state_selective(0x78, 0x1234, 1, 43)
    assert lss.send_identify_remote_slave(0x78, 0x1234, 0, 5, 0, 100)
    assert not lss.send_identify_remote_slave(0x78, 0x1234, 0, 5, 43, 100)


def test_no_answer_is_an_lss_error(network: canola.Network) -> None:
    with pytest.raises(canola.LssError, match="no LSS answer"):
        network.lss.inquire_node_id()
    with pytest.raises(ValueError):
        network.lss.inquire_lss_address(0x42)
    with pytest.raises(ValueError):
        network.lss.configure_node_id(0)
