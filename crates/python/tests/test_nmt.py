"""NMT through python-canopen's vocabulary: state, commands, boot-up and heartbeat waits."""

from __future__ import annotations

import pytest

import canola
from conftest import EDS


def test_state_is_what_the_node_reports(node: canola.RemoteNode) -> None:
    assert node.nmt.wait_for_heartbeat(2) == "PRE-OPERATIONAL"
    assert node.nmt.state == "PRE-OPERATIONAL"
    node.nmt.state = "OPERATIONAL"
    assert node.nmt.wait_for_heartbeat(2) == "OPERATIONAL"
    assert node.nmt.state == "OPERATIONAL"
    node.nmt.state = "STOPPED"
    assert node.nmt.wait_for_heartbeat(2) == "STOPPED"


def test_reset_then_wait_for_bootup(node: canola.RemoteNode) -> None:
    node.nmt.state = "OPERATIONAL"
    assert node.nmt.wait_for_heartbeat(2) == "OPERATIONAL"
    node.nmt.state = "RESET"
    node.nmt.wait_for_bootup(2)
    assert node.nmt.wait_for_heartbeat(2) == "PRE-OPERATIONAL"


def test_waits_time_out_with_nmt_error(network: canola.Network) -> None:
    absent = network.add_node(9, str(EDS))
    with pytest.raises(canola.NmtError, match="node 9"):
        absent.nmt.wait_for_bootup(0.5)
    with pytest.raises(canola.NmtError, match="node 9"):
        absent.nmt.wait_for_heartbeat(0.5)
    assert absent.nmt.state == "INITIALISING"


def test_commands_outside_cia_301_are_refused(node: canola.RemoteNode) -> None:
    with pytest.raises(ValueError, match="SLEEP"):
        node.nmt.state = "SLEEP"


@pytest.mark.parametrize("timeout", [-1.0, float("nan"), float("inf"), 1e300])
def test_timeouts_out_of_range_are_value_errors(node: canola.RemoteNode, timeout: float) -> None:
    with pytest.raises(ValueError, match="a time in seconds"):
        node.nmt.wait_for_bootup(timeout)
    with pytest.raises(ValueError, match="a time in seconds"):
        node.nmt.wait_for_heartbeat(timeout)


def test_node_guarding_gives_the_state(node: canola.RemoteNode) -> None:
    node.sdo["Producer heartbeat time"].raw = 0  # no heartbeat
    with pytest.raises(canola.NmtError):
        node.nmt.wait_for_heartbeat(1.0)
    node.nmt.start_node_guarding(0.1)
    assert node.nmt.wait_for_heartbeat(1.0) == "PRE-OPERATIONAL"
    node.nmt.state = "OPERATIONAL"
    node.nmt.wait_for_heartbeat(1.0)
    assert node.nmt.wait_for_heartbeat(1.0) == "OPERATIONAL"
    node.nmt.stop_node_guarding()
    with pytest.raises(canola.NmtError):
        node.nmt.wait_for_heartbeat(1.0)


def test_heartbeat_callbacks_get_the_state(node: canola.RemoteNode) -> None:
    got: list[int] = []
    node.nmt.add_heartbeat_callback(got.append)
    node.nmt.wait_for_heartbeat(5.0)
    node.nmt.wait_for_heartbeat(5.0)
    assert got == [127, 127]
    node.nmt.state = "OPERATIONAL"
    node.nmt.wait_for_heartbeat(5.0)
    assert got[-1] == 5
