"""canola: a CANopen master for Python, in python-canopen's vocabulary.

`import canola as canopen` runs python-canopen programs that use the calls this package has so
far (see the README's Python section); every blocking SDO call has an awaitable twin (`aupload`,
`adownload`, `aget_raw`, `aset_raw`) that runs on the stack's own driver.
"""

from __future__ import annotations

import os
from collections.abc import Awaitable, Iterator
from types import TracebackType
from typing import Any, Optional, Type, Union, final

__version__: str
__all__ = [
    "MemoryBus",
    "NetworkError",
    "Network",
    "NmtError",
    "NmtMaster",
    "RemoteNode",
    "SdoAbortedError",
    "SdoArray",
    "SdoClient",
    "SdoCommunicationError",
    "SdoError",
    "SdoRecord",
    "SdoVariable",
    "SimDevice",
    "__version__",
]

#: An object dictionary as `add_node` and `RemoteNode` take it: an EDS/DCF path or its bytes.
_EdsSource = Union[str, "os.PathLike[str]", bytes]
#: A value `raw` gives or takes, decoded by the object's data type.
_RawValue = Union[int, bool, float, str, bytes]

class SdoError(Exception):
    """An SDO transfer failed (base of SdoAbortedError and SdoCommunicationError)."""

    node: int
    index: int
    subindex: int

class SdoAbortedError(SdoError):
    """The node refused an SDO transfer; `str()` names node, object and the abort's meaning."""

    code: int

class SdoCommunicationError(SdoError):
    """No or no valid answer to an SDO transfer (timeout, protocol error, bus failure)."""

class NmtError(Exception):
    """An NMT wait ended without what it waited for (no boot-up, no heartbeat)."""

@final
class NetworkError(Exception):
    """The bus could not be opened, failed, or is not connected."""

@final
class MemoryBus:
    """An in-memory CAN bus in this process, on a virtual clock unless `realtime`."""

    def __new__(cls, realtime: bool = False) -> MemoryBus: ...
    @staticmethod
    def virtual_channel(channel: str) -> MemoryBus:
        """The real-time in-process bus `connect(interface="virtual", channel=...)` joins."""
    @property
    def realtime(self) -> bool: ...
    def attach(self, device: SimDevice) -> None:
        """Puts a simulated device on the bus (a device goes on one bus once)."""

@final
class SimDevice:
    """A simulated CANopen device built from an EDS."""

    @staticmethod
    def from_eds(eds: _EdsSource, node_id: int) -> SimDevice: ...
    @property
    def id(self) -> int: ...

@final
class Network:
    """The master side of one CAN bus; a mapping of node-ID to node."""

    def __new__(cls, bus: Optional[MemoryBus] = None) -> Network: ...
    @staticmethod
    def open(spec: str) -> Network:
        """A network on a bus spec of this stack: "can0", "udp[:GROUP[:PORT]][@IFACE]", "slcan:PATH[@BITRATE]"."""
    def connect(self, *args: Any, **kwargs: Any) -> Network:
        """Connects as python-can's `can.Bus(interface=..., channel=..., bitrate=...)`."""
    def disconnect(self) -> None: ...
    def add_node(
        self,
        node: Union[int, RemoteNode],
        object_dictionary: Optional[_EdsSource] = None,
        upload_eds: bool = False,
    ) -> RemoteNode: ...
    def keys(self) -> list[int]: ...
    def __getitem__(self, node_id: int, /) -> RemoteNode: ...
    def __contains__(self, node_id: object, /) -> bool: ...
    def __len__(self) -> int: ...
    def __iter__(self) -> Iterator[int]: ...
    def __enter__(self) -> Network: ...
    def __exit__(
        self,
        exc_type: Optional[Type[BaseException]],
        exc: Optional[BaseException],
        tb: Optional[TracebackType],
    ) -> bool: ...

@final
class RemoteNode:
    """A CANopen node as the master sees it."""

    def __new__(
        cls, node_id: int, object_dictionary: Optional[_EdsSource] = None
    ) -> RemoteNode: ...
    @property
    def id(self) -> int: ...
    @property
    def sdo(self) -> SdoClient: ...
    @property
    def nmt(self) -> NmtMaster: ...

@final
class NmtMaster:
    """A node's NMT: `state` as the node last reported it; setting it sends the command."""

    @property
    def state(self) -> str: ...
    @state.setter
    def state(self, state: str) -> None: ...
    def wait_for_bootup(self, timeout: float = 10.0) -> None: ...
    def wait_for_heartbeat(self, timeout: float = 10.0) -> str: ...

@final
class SdoVariable:
    """One value of the node's dictionary, read and written over SDO."""

    @property
    def raw(self) -> Any: ...
    @raw.setter
    def raw(self, value: _RawValue) -> None: ...
    @property
    def data(self) -> bytes: ...
    @data.setter
    def data(self, data: Union[bytes, bytearray]) -> None: ...
    def read(self, fmt: str = "raw") -> Any: ...
    def write(self, value: _RawValue, fmt: str = "raw") -> None: ...
    def aget_raw(self) -> Awaitable[Any]: ...
    def aset_raw(self, value: _RawValue) -> Awaitable[None]: ...
    @property
    def index(self) -> int: ...
    @property
    def subindex(self) -> int: ...
    @property
    def name(self) -> str: ...

@final
class SdoRecord:
    """A RECORD object: sub-objects by sub-index or name."""

    def __getitem__(self, key: Union[int, str], /) -> SdoVariable: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __len__(self) -> int: ...
    def __iter__(self) -> Iterator[int]: ...
    @property
    def index(self) -> int: ...

@final
class SdoArray:
    """An ARRAY object: elements by sub-index or name; `len()` reads sub-index 0."""

    def __getitem__(self, key: Union[int, str], /) -> SdoVariable: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __len__(self) -> int: ...
    def __iter__(self) -> Iterator[int]: ...
    @property
    def index(self) -> int: ...

@final
class SdoClient:
    """A node's SDO client: objects by index or name, raw upload and download."""

    def __getitem__(self, key: Union[int, str], /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def upload(self, index: int, subindex: int) -> bytes: ...
    def download(
        self, index: int, subindex: int, data: Union[bytes, bytearray], force_segment: bool = False
    ) -> None: ...
    def aupload(self, index: int, subindex: int) -> Awaitable[bytes]: ...
    def adownload(
        self, index: int, subindex: int, data: Union[bytes, bytearray], force_segment: bool = False
    ) -> Awaitable[None]: ...
