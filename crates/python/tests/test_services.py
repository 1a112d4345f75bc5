"""The network's services: NMT to every node, the SYNC producer and the node scanner."""

from __future__ import annotations

import pytest

import canola
from conftest import EDS


def test_network_nmt_commands_every_node(network: canola.Network, node: canola.RemoteNode) -> None:
    network.nmt.state = "OPERATIONAL"
    assert network.nmt.state == "OPERATIONAL"
    assert node.nmt.wait_for_heartbeat(5.0) == "OPERATIONAL"
    network.nmt.send_command(0x80)
    assert network.nmt.state == "PRE-OPERATIONAL"
    assert node.nmt.wait_for_heartbeat(5.0) == "PRE-OPERATIONAL"
    with pytest.raises(ValueError):
        network.nmt.send_command(0x42)
    with pytest.raises(ValueError):
        network.nmt.wait_for_bootup(1.0)


def test_node_send_command(node: canola.RemoteNode) -> None:
    node.nmt.send_command(0x01)
    assert node.nmt.wait_for_heartbeat(5.0) == "OPERATIONAL"
    node.nmt.send_command(0x02)
    assert node.nmt.wait_for_heartbeat(5.0) == "STOPPED"


def synchronous_tpdo(node: canola.RemoteNode) -> canola.PdoMap:
    """TPDO1 sent on every SYNC (transmission type 1), the node operational."""
    node.tpdo.read()
    tpdo1 = node.tpdo[1]
    tpdo1.trans_type = 1
    tpdo1.save()
    node.nmt.state = "OPERATIONAL"
    return tpdo1


def test_sync_transmit_sends_one_sync(network: canola.Network, node: canola.RemoteNode) -> None:
    tpdo1 = synchronous_tpdo(node)
    assert tpdo1.wait_for_reception(0.5) is None  # no SYNC, no TPDO
    network.sync.transmit()
    assert tpdo1.wait_for_reception(0.5) is not None
    assert tpdo1.wait_for_reception(0.5) is None
    assert network.sync.cob_id == 0x80


def test_sync_start_and_stop(network: canola.Network, node: canola.RemoteNode) -> None:
    tpdo1 = synchronous_tpdo(node)
    network.sync.start(0.01)
    assert network.sync.period == 0.01
    t1 = tpdo1.wait_for_reception(1.0)
    t2 = tpdo1.wait_for_reception(1.0)
    assert t1 is not None and t2 is not None
    assert t2 - t1 == pytest.approx(0.01, abs=0.002)
    network.sync.stop()
    assert network.sync.period is None
    assert tpdo1.wait_for_reception(0.5) is None
    with pytest.raises(ValueError):
        network.sync.start()


def test_scanner_finds_the_nodes(bus: canola.MemoryBus, network: canola.Network) -> None:
    bus.attach(canola.SimDevice.from_eds(str(EDS), 9))
    network.scanner.search()
    assert network.scanner.nodes == [5, 9]
    network.scanner.reset()
    assert network.scanner.nodes == []
    network.scanner.search(limit=8)
    assert network.scanner.nodes == [5]


def test_network_keys_are_ints(network: canola.Network, node: canola.RemoteNode) -> None:
    assert network.keys() == [5]
