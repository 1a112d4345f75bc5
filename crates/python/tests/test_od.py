"""import_od and node.object_dictionary: the stack's parsed EDS in python-canopen's names."""

from __future__ import annotations

import pytest

import canola
from conftest import EDS


def test_import_od_looks_up_objects_by_index_and_name() -> None:
    od = canola.import_od(str(EDS), node_id=5)
    assert od.node_id == 5
    assert 0x1017 in od and "Identity object" in od and 0x0FFF not in od
    heartbeat = od["Producer heartbeat time"]
    assert isinstance(heartbeat, canola.ODVariable)
    assert (heartbeat.index, heartbeat.subindex) == (0x1017, 0)
    assert heartbeat.data_type == 0x0006  # UNSIGNED16
    assert heartbeat.access_type == "rw"
    assert heartbeat.default == 500
    identity = od[0x1018]
    assert isinstance(identity, canola.ODRecord)
    assert identity.name == "Identity Object"  # as the EDS spells it
    vendor = identity[1]
    assert isinstance(vendor, canola.ODVariable)
    assert vendor.qualname.startswith("Identity Object.")
    assert identity[vendor.name].subindex == 1
    assert list(identity)[0] == 0 and len(identity) == len(list(identity))
    tpdo1 = od[0x1800]
    assert isinstance(tpdo1, canola.ODRecord)
    cob = tpdo1[1]
    assert isinstance(cob, canola.ODVariable)
    assert cob.default == 0x185  # $NODEID resolved
    sensor = od["Sensor Value 1.Value"]
    assert isinstance(sensor, canola.ODVariable) and sensor.pdo_mappable
    assert len(od) == len(list(od)) > 10
    with pytest.raises(KeyError):
        od["no such object"]


def test_a_node_has_its_dictionary(network: canola.Network) -> None:
    od = canola.import_od(str(EDS))
    node = network.add_node(5, od)
    assert node.object_dictionary is not None
    assert node.object_dictionary.node_id == 5
    assert node.sdo["Producer heartbeat time"].raw == 500
    assert canola.RemoteNode(6).object_dictionary is None
