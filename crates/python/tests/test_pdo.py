"""PDOs: node.tpdo / node.rpdo read, remapped and saved by SDO, TPDOs received and decoded,
RPDOs sent by the master, against the simulated device."""

from __future__ import annotations

import pytest

import canola

SENSOR = "Sensor Value 1.Value"  # 0x2500:01, REAL32, mapped first in TPDO1 by default
CONTROL = "Control Value 1.Value"  # 0x2540:01, REAL32, mapped first in RPDO1 by default


def test_read_gives_the_tpdo_parameters_and_mapping(node: canola.RemoteNode) -> None:
    node.tpdo.read()
    tpdo1 = node.tpdo[1]
    assert node.tpdo.map[1].cob_id == tpdo1.cob_id == 0x185
    assert tpdo1.enabled
    assert tpdo1.trans_type == 254
    assert tpdo1.event_timer == 1000
    assert tpdo1.inhibit_time == 5000
    assert tpdo1.name == "TxPDO1_node5"
    assert [(v.index, v.subindex, v.length) for v in tpdo1] == [
        (0x2500, 1, 32),
        (0x2501, 1, 32),
    ]
    assert tpdo1[0].index == 0x2500
    assert tpdo1[SENSOR].index == 0x2500
    assert node.tpdo[SENSOR].index == 0x2500
    assert node.tpdo[0x1A00].cob_id == 0x185
    assert len(node.tpdo) >= 4 and 1 in node.tpdo
    assert list(node.tpdo)[:4] == [1, 2, 3, 4]


def test_a_map_before_read_says_to_read(node: canola.RemoteNode) -> None:
    with pytest.raises(ValueError, match="read"):
        _ = node.tpdo[1].cob_id


def test_received_tpdo_values_are_decoded(node: canola.RemoteNode) -> None:
    node.tpdo.read()
    tpdo1 = node.tpdo[1]
    assert tpdo1[SENSOR].raw is None  # nothing received yet
    node.sdo[0x2500][1].raw  # the device answers; it sends no PDO before OPERATIONAL
    assert tpdo1.wait_for_reception(0.5) is None
    node.nmt.state = "OPERATIONAL"
    t = tpdo1.wait_for_reception(5.0)
    assert t is not None and tpdo1.timestamp == t
    assert tpdo1[SENSOR].raw == 0.0
    assert len(tpdo1.data) == 8
    # The event timer (1000 ms) sends it again.
    t2 = tpdo1.wait_for_reception(5.0)
    assert t2 is not None and 0.9 <= t2 - t <= 1.1


def test_callbacks_get_the_map_on_every_reception(node: canola.RemoteNode) -> None:
    node.tpdo.read()
    got: list[tuple[str, object]] = []
    node.tpdo[1].add_callback(lambda m: got.append((m.name, m[SENSOR].raw)))
    node.nmt.state = "OPERATIONAL"
    assert node.tpdo[1].wait_for_reception(5.0) is not None
    assert got and got[-1] == ("TxPDO1_node5", 0.0)
    before = len(got)
    node.tpdo[1].wait_for_reception(5.0)
    assert len(got) > before


def test_remap_and_save_writes_the_node(node: canola.RemoteNode) -> None:
    node.tpdo.read()
    tpdo1 = node.tpdo[1]
    tpdo1.clear()
    var = tpdo1.add_variable(0x2501, 1)
    assert (var.index, var.subindex, var.length) == (0x2501, 1, 32)
    tpdo1.add_variable("Sensor Value 1", "Value")
    tpdo1.event_timer = 200
    tpdo1.trans_type = 255
    tpdo1.inhibit_time = 0  # was 0.5 s, longer than the event timer
    tpdo1.save()
    assert node.sdo[0x1A00][0].raw == 2
    assert node.sdo[0x1A00][1].raw == 0x25010120
    assert node.sdo[0x1A00][2].raw == 0x25000120
    assert node.sdo[0x1800][5].raw == 200
    assert node.sdo[0x1800][2].raw == 255
    assert node.sdo[0x1800][3].raw == 0
    # A fresh read sees the same; the master decodes the new mapping.
    node.tpdo.read()
    assert [v.index for v in node.tpdo[1]] == [0x2501, 0x2500]
    node.nmt.state = "OPERATIONAL"
    t = node.tpdo[1].wait_for_reception(5.0)
    assert t is not None
    t2 = node.tpdo[1].wait_for_reception(5.0)
    assert t2 is not None and 0.15 <= t2 - t <= 0.25
    assert node.tpdo[1][SENSOR].raw == 0.0


def test_a_pdo_can_be_disabled(node: canola.RemoteNode) -> None:
    node.tpdo.read()
    node.tpdo[1].enabled = False
    node.tpdo.save()
    assert node.sdo[0x1800][1].raw & 0x80000000
    node.nmt.state = "OPERATIONAL"
    assert node.tpdo[1].wait_for_reception(2.0) is None


def test_rpdo_transmit_sets_the_node_value(node: canola.RemoteNode) -> None:
    node.rpdo.read()
    rpdo1 = node.rpdo[1]
    assert rpdo1.cob_id == 0x205
    assert rpdo1.name == "RxPDO1_node5"
    node.nmt.state = "OPERATIONAL"
    rpdo1[CONTROL].raw = 1.5
    assert rpdo1[CONTROL].raw == 1.5
    rpdo1.transmit()
    assert node.sdo[0x2540][1].raw == 1.5
    rpdo1[CONTROL].raw = -2.25
    rpdo1.transmit()
    assert node.sdo[0x2540][1].raw == -2.25
    rpdo1.transmit()  # unchanged: sent again
    assert node.sdo[0x2540][1].raw == -2.25


def test_rpdo_start_sends_periodically_until_stop(node: canola.RemoteNode) -> None:
    node.rpdo.read()
    rpdo1 = node.rpdo[1]
    node.nmt.state = "OPERATIONAL"
    rpdo1[CONTROL].raw = 3.0
    rpdo1.start(0.05)
    assert node.sdo[0x2540][1].raw == 3.0
    rpdo1[CONTROL].raw = 4.0  # a started RPDO sends the change
    assert node.sdo[0x2540][1].raw == 4.0
    rpdo1.stop()
    node.rpdo.stop()
    assert rpdo1.period == 0.05  # start() again sends at the same period
    rpdo1.period = None
    with pytest.raises(ValueError, match="period"):
        rpdo1.start()


def test_a_tpdo_is_not_the_masters_to_send(node: canola.RemoteNode) -> None:
    node.tpdo.read()
    with pytest.raises(ValueError, match="RPDO"):
        node.tpdo[1].transmit()
    with pytest.raises(ValueError):
        node.tpdo[1][SENSOR].raw = 1.0
    with pytest.raises(KeyError):
        node.tpdo[1]["no such object"]
    with pytest.raises(KeyError):
        node.tpdo[0x3000]


def test_callbacks_come_by_themselves_on_a_real_time_bus() -> None:
    """On a network driven in the background, callbacks run without a call that waits."""
    import time

    from conftest import EDS

    bus = canola.MemoryBus(realtime=True)
    bus.attach(canola.SimDevice.from_eds(str(EDS), 5))
    with canola.Network(bus) as net:
        node = net.add_node(5, str(EDS))
        node.tpdo.read()
        node.tpdo[1].event_timer = 10
        node.tpdo[1].inhibit_time = 0
        node.tpdo.save()
        got: list[float] = []
        node.tpdo[1].add_callback(lambda m: got.append(m.timestamp or 0.0))
        net.nmt.state = "OPERATIONAL"
        end = time.monotonic() + 10
        while len(got) < 3 and time.monotonic() < end:
            time.sleep(0.01)
        assert len(got) >= 3


def test_an_rpdo_remapped_sends_what_it_maps_now(node: canola.RemoteNode) -> None:
    node.rpdo.read()
    rpdo1 = node.rpdo[1]
    node.nmt.state = "OPERATIONAL"
    rpdo1[CONTROL].raw = 5.0
    rpdo1.transmit()
    rpdo1.clear()
    rpdo1.add_variable("Control Value 2.Value")
    rpdo1.save()
    rpdo1["Control Value 2.Value"].raw = 6.0
    rpdo1.transmit()  # the value given to Control Value 1 is not sent any more
    assert node.sdo["Control Value 2.Value"].raw == 6.0
    assert node.sdo[CONTROL].raw == 5.0


def test_remote_request_of_an_rtr_only_tpdo(node: canola.RemoteNode) -> None:
    node.tpdo.read()
    tpdo1 = node.tpdo[1]
    assert tpdo1.rtr_allowed and tpdo1.is_periodic is False
    tpdo1.trans_type = 253  # sent on a remote request only
    tpdo1.save()
    node.nmt.state = "OPERATIONAL"
    assert tpdo1.wait_for_reception(1.5) is None
    tpdo1.remote_request()
    assert tpdo1.wait_for_reception(0.5) is not None


def test_period_set_before_start(node: canola.RemoteNode) -> None:
    node.rpdo.read()
    rpdo1 = node.rpdo[1]
    node.nmt.state = "OPERATIONAL"
    rpdo1.period = 0.02
    assert rpdo1.is_periodic
    rpdo1.start()
    rpdo1[CONTROL].raw = 7.0
    rpdo1.update()
    assert node.sdo[CONTROL].raw == 7.0
    rpdo1.stop()
    assert rpdo1.period == 0.02


def test_a_reconnected_network_keeps_its_nodes() -> None:
    """After disconnect() and connect(), the nodes are on the new connection with their
    dictionaries, and TPDOs read again are received."""
    from conftest import EDS

    canola.MemoryBus.virtual_channel("pdo-reconnect").attach(
        canola.SimDevice.from_eds(str(EDS), 5)
    )
    net = canola.Network()
    net.connect(interface="virtual", channel="pdo-reconnect")
    try:
        node = net.add_node(5, str(EDS))
        node.tpdo.read()
        node.tpdo[1].event_timer = 20
        node.tpdo[1].inhibit_time = 0
        node.tpdo.save()
        net.disconnect()
        net.connect(interface="virtual", channel="pdo-reconnect")
        assert node.sdo["Producer heartbeat time"].raw == 500  # typed by the EDS
        node.tpdo.read()
        node.nmt.state = "OPERATIONAL"
        assert node.tpdo[1].wait_for_reception(5.0) is not None
        assert node.tpdo[1][SENSOR].raw == 0.0
    finally:
        net.disconnect()


def test_node_pdo_holds_both_directions(node: canola.RemoteNode) -> None:
    node.pdo.read()
    assert node.pdo[0x1A00].cob_id == 0x185
    assert node.pdo[0x1600].cob_id == 0x205
    assert node.pdo.tx[1].name == "TxPDO1_node5"
    assert node.pdo.rx[1].name == "RxPDO1_node5"
    assert node.pdo[CONTROL].index == 0x2540
    assert node.pdo[SENSOR].index == 0x2500
    with pytest.raises(KeyError):
        node.pdo[0x1800]
    node.pdo.save()  # nothing changed: nothing written
    node.pdo.stop()
