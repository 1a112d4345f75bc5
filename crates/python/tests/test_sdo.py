"""SDO through python-canopen's vocabulary against the simulated device."""

from __future__ import annotations

import pytest

import canola
from conftest import EDS


def test_raw_by_name_reads_and_writes_the_value_typed_by_the_eds(node: canola.RemoteNode) -> None:
    var = node.sdo["Producer heartbeat time"]
    assert isinstance(var, canola.SdoVariable)
    assert (var.index, var.subindex) == (0x1017, 0)
    assert var.raw == 500
    var.raw = 250
    assert node.sdo["Producer heartbeat time"].raw == 250
    # UNSIGNED16: two bytes went over the bus.
    assert node.sdo.upload(0x1017, 0) == (250).to_bytes(2, "little")


def test_record_by_index_and_sub_index_and_by_names(node: canola.RemoteNode) -> None:
    identity = node.sdo[0x1018]
    assert isinstance(identity, canola.SdoRecord)
    assert identity[1].raw == 0x39
    assert node.sdo["Identity object"]["Vendor ID"].raw == 0x39
    assert node.sdo["identity object.vendor id"].raw == 0x39
    assert 1 in identity and 9 not in identity
    assert list(identity)[:2] == [0, 1]


def test_visible_string_reads_as_str(node: canola.RemoteNode) -> None:
    assert node.sdo["Manufacturer device name"].raw == "Buerkert generic device"


def test_array_length_is_read_from_the_node(node: canola.RemoteNode) -> None:
    consumers = node.sdo[0x1016]
    assert isinstance(consumers, canola.SdoArray)
    assert len(consumers) == consumers[0].raw
    assert len(consumers) > 0


def test_upload_and_download_move_raw_bytes(node: canola.RemoteNode) -> None:
    node.sdo.download(0x1017, 0, b"\x2c\x01")
    assert node.sdo.upload(0x1017, 0) == b"\x2c\x01"
    assert node.sdo[0x1017].raw == 300
    node.sdo.download(0x1017, 0, bytearray(b"\x64\x00"), force_segment=True)
    assert node.sdo[0x1017].data == b"\x64\x00"


def test_abort_is_sdo_aborted_error_naming_node_object_and_meaning(
    node: canola.RemoteNode,
) -> None:
    with pytest.raises(canola.SdoAbortedError) as caught:
        node.sdo[0x1018][1].raw = 1
    e = caught.value
    assert e.code == 0x06010002
    assert (e.node, e.index, e.subindex) == (5, 0x1018, 1)
    text = str(e)
    assert "node 5" in text and "0x1018:01" in text, text
    assert "read only" in text.lower(), text
    assert isinstance(e, canola.SdoError)

    with pytest.raises(canola.SdoAbortedError) as caught:
        node.sdo.upload(0x2FFF, 0)
    assert caught.value.code == 0x06020000
    assert "does not exist" in str(caught.value)


def test_silent_node_is_sdo_communication_error(network: canola.Network) -> None:
    absent = network.add_node(9, str(EDS))
    with pytest.raises(canola.SdoCommunicationError) as caught:
        absent.sdo.upload(0x1000, 0)
    e = caught.value
    assert (e.node, e.index, e.subindex) == (9, 0x1000, 0)
    assert "node 9" in str(e) and "timeout" in str(e).lower(), str(e)
    assert not isinstance(e, canola.SdoAbortedError)


def test_values_that_do_not_fit_are_refused_before_sending(node: canola.RemoteNode) -> None:
    with pytest.raises(ValueError, match="does not fit"):
        node.sdo["Producer heartbeat time"].raw = 70000
    with pytest.raises(TypeError):
        node.sdo["Producer heartbeat time"].raw = [1]
    assert node.sdo["Producer heartbeat time"].raw == 500


def test_unknown_names_and_indices_are_key_errors(node: canola.RemoteNode) -> None:
    with pytest.raises(KeyError, match="no object"):
        node.sdo["No such object"]
    with pytest.raises(KeyError):
        node.sdo[0x2FFF]
    with pytest.raises(KeyError):
        node.sdo[0x1018][42]
    assert "Producer heartbeat time" in node.sdo
    assert 0x2FFF not in node.sdo


def test_remote_node_made_first_then_added(network: canola.Network) -> None:
    node = canola.RemoteNode(5, EDS.read_bytes())
    with pytest.raises(canola.NetworkError, match="not on a network"):
        node.sdo[0x1017].raw
    assert network.add_node(node) is node
    assert network[5] is node and 5 in network and list(network) == [5]
    assert node.sdo[0x1017].raw == 500


def test_phys_is_raw_with_factor_one(node: canola.RemoteNode) -> None:
    var = node.sdo["Producer heartbeat time"]
    var.phys = 300
    assert var.raw == 300 and var.phys == 300
    assert var.read("phys") == 300
    var.write(400, "phys")
    assert var.raw == 400
    with pytest.raises(ValueError):
        var.read("desc")


def test_bits_read_and_write_the_value(node: canola.RemoteNode) -> None:
    var = node.sdo[0x1017]
    var.raw = 0b1010
    bits = var.bits
    assert (bits[0], bits[1], bits[3]) == (0, 1, 1)
    assert bits[0:4] == 0b1010
    assert bits[[1, 3]] == 0b101
    bits[0] = 1
    assert var.raw == 0b1011
    bits[4:8] = 0xF
    assert var.raw == 0xFB
    with pytest.raises(TypeError):
        _ = node.sdo["Manufacturer device name"].bits
    with pytest.raises(ValueError):
        bits[64]


STORE_OBJECTS = b"""
[1010]
ParameterName=Store parameters
ObjectType=0x8
SubNumber=2

[1010sub0]
ParameterName=Highest sub-index supported
ObjectType=0x7
DataType=0x0005
AccessType=ro
DefaultValue=1
PDOMapping=0

[1010sub1]
ParameterName=Save all parameters
ObjectType=0x7
DataType=0x0007
AccessType=rw
DefaultValue=1
PDOMapping=0

[1011]
ParameterName=Restore default parameters
ObjectType=0x8
SubNumber=2

[1011sub0]
ParameterName=Highest sub-index supported
ObjectType=0x7
DataType=0x0005
AccessType=ro
DefaultValue=1
PDOMapping=0

[1011sub1]
ParameterName=Restore all default parameters
ObjectType=0x7
DataType=0x0007
AccessType=rw
DefaultValue=1
PDOMapping=0
"""


def test_store_without_0x1010_is_an_abort(node: canola.RemoteNode) -> None:
    with pytest.raises(canola.SdoAbortedError) as info:
        node.store()
    assert info.value.code == 0x06020000


def test_store_and_restore_survive_a_reset() -> None:
    from conftest import EDS

    eds = EDS.read_bytes() + STORE_OBJECTS
    bus = canola.MemoryBus()
    bus.attach(canola.SimDevice.from_eds(eds, 5))
    with canola.Network(bus) as net:
        node = net.add_node(5, eds)
        node.sdo["Producer heartbeat time"].raw = 300
        node.store()
        node.nmt.state = "RESET"
        node.nmt.wait_for_bootup(5.0)
        assert node.sdo["Producer heartbeat time"].raw == 300
        node.restore()
        node.nmt.state = "RESET"
        node.nmt.wait_for_bootup(5.0)
        assert node.sdo["Producer heartbeat time"].raw == 500


def test_open_reads_and_writes_the_value_as_a_file(node: canola.RemoteNode) -> None:
    var = node.sdo["Manufacturer device name"]
    with var.open("rb") as f:
        assert f.read() == b"Buerkert generic device"
    with var.open("r", encoding="ascii", block_transfer=True) as t:
        assert t.read() == "Buerkert generic device"
    text = "line one\nline two"
    user = node.sdo[0x2002]["User Description"]
    with user.open("wt", encoding="ascii") as w:
        w.write(text)
    assert user.raw == text
    with user.open("wb", block_transfer=True) as b:
        b.write(b"bytes ")
        b.write(b"written")
    assert user.raw == "bytes written"
    with pytest.raises(ValueError):
        user.open("x")
