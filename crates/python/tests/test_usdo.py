"""USDO (CANopen FD, node.usdo) against a simulated FD device on an in-memory CAN FD bus."""

from __future__ import annotations

from typing import Iterator

import pytest

import canola

#: A device marked CANopen FD in its [DeviceInfo], with a string, a DOMAIN, a read-only and a
#: read-write object.
FD_EDS = b"""[FileInfo]
FileName=fd.eds
FileVersion=1
EDSVersion=4.0
[DeviceInfo]
VendorName=test
ProductName=fd device
VendorNumber=0x39
ProductNumber=3
CANopenFD=1
[MandatoryObjects]
SupportedObjects=3
1=0x1000
2=0x1001
3=0x1018
[1000]
ParameterName=Device type
ObjectType=0x7
DataType=0x0007
AccessType=ro
DefaultValue=0x20191
PDOMapping=0
[1001]
ParameterName=Error register
ObjectType=0x7
DataType=0x0005
AccessType=ro
DefaultValue=0
PDOMapping=0
[1018]
ParameterName=Identity object
ObjectType=0x9
SubNumber=2
[1018sub0]
ParameterName=Number of entries
ObjectType=0x7
DataType=0x0005
AccessType=ro
DefaultValue=1
PDOMapping=0
[1018sub1]
ParameterName=Vendor-ID
ObjectType=0x7
DataType=0x0007
AccessType=ro
DefaultValue=0x39
PDOMapping=0
[OptionalObjects]
SupportedObjects=2
1=0x1008
2=0x1017
[1008]
ParameterName=Manufacturer device name
ObjectType=0x7
DataType=0x0009
AccessType=const
DefaultValue=FD test device
PDOMapping=0
[1017]
ParameterName=Producer heartbeat time
ObjectType=0x7
DataType=0x0006
AccessType=rw
DefaultValue=0
PDOMapping=0
[ManufacturerObjects]
SupportedObjects=2
1=0x2000
2=0x2100
[2000]
ParameterName=Setpoint
ObjectType=0x7
DataType=0x0006
AccessType=rw
DefaultValue=100
PDOMapping=0
[2100]
ParameterName=Blob
ObjectType=0x7
DataType=0x000F
AccessType=rw
PDOMapping=0
"""


@pytest.fixture
def fd_node() -> Iterator[canola.RemoteNode]:
    """Node 5, CANopen FD, on a CAN FD bus."""
    bus = canola.MemoryBus(fd=True)
    bus.attach(canola.SimDevice.from_eds(FD_EDS, 5))
    with canola.Network(bus) as net:
        yield net.add_node(5, FD_EDS)


def test_the_eds_marks_the_node_fd(fd_node: canola.RemoteNode) -> None:
    assert fd_node.is_fd
    fd_node.is_fd = False
    assert not fd_node.is_fd
    fd_node.is_fd = True
    assert fd_node.is_fd


def test_expedited_reads_and_writes_typed_by_the_dictionary(
    fd_node: canola.RemoteNode,
) -> None:
    assert fd_node.usdo[0x1000].raw == 0x20191
    assert fd_node.usdo["Identity object"][1].raw == 0x39
    assert fd_node.usdo["Identity object"]["Vendor-ID"].raw == 0x39
    assert fd_node.usdo["Manufacturer device name"].raw == "FD test device"
    fd_node.usdo["Setpoint"].raw = 1234
    assert fd_node.usdo[0x2000].raw == 1234
    # Another protocol path through the same device: classic SDO reads what USDO wrote.
    assert fd_node.sdo[0x2000].raw == 1234
    with pytest.raises(ValueError, match="does not fit"):
        fd_node.usdo[0x2000].raw = 70000
    assert 0x2000 in fd_node.usdo and 0x3000 not in fd_node.usdo


def test_segmented_domain_beyond_56_bytes(fd_node: canola.RemoteNode) -> None:
    blob = bytes(range(256)) * 4
    fd_node.usdo[0x2100].data = blob
    assert fd_node.usdo[0x2100].data == blob
    assert fd_node.usdo.upload(0x2100, 0) == blob
    fd_node.usdo.download(0x2100, 0, b"short")
    assert fd_node.sdo.upload(0x2100, 0) == b"short"


def test_a_server_abort_is_the_sdo_aborted_error(fd_node: canola.RemoteNode) -> None:
    with pytest.raises(canola.SdoAbortedError) as err:
        fd_node.usdo[0x1000].raw = 1  # read-only
    assert err.value.code == 0x06010002
    with pytest.raises(canola.SdoAbortedError) as err:
        fd_node.usdo.upload(0x3000, 0)
    assert err.value.code == 0x06020000


def test_a_classic_bus_refuses_usdo() -> None:
    bus = canola.MemoryBus()
    bus.attach(canola.SimDevice.from_eds(FD_EDS, 5))
    with canola.Network(bus) as net:
        node = net.add_node(5, FD_EDS)
        with pytest.raises(canola.SdoCommunicationError, match="FD not supported"):
            node.usdo[0x1000].raw
