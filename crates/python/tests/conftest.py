"""Fixtures of the canola pytest suite: a simulated device on an in-memory bus."""

from __future__ import annotations

from pathlib import Path
from typing import Iterator

import pytest

import canola

#: The repository's EDS files (a Bürkert device and a CiA 402 servo).
EDS_DIR = Path(__file__).resolve().parents[3] / "eds"
EDS = EDS_DIR / "burkert-generic.eds"


@pytest.fixture
def bus() -> canola.MemoryBus:
    """An in-memory bus on a virtual clock with the simulated device of node 5 on it."""
    bus = canola.MemoryBus()
    bus.attach(canola.SimDevice.from_eds(str(EDS), 5))
    return bus


@pytest.fixture
def network(bus: canola.MemoryBus) -> Iterator[canola.Network]:
    """A network on `bus`, disconnected after the test."""
    with canola.Network(bus) as net:
        yield net


@pytest.fixture
def node(network: canola.Network) -> canola.RemoteNode:
    """Node 5, added with its EDS."""
    return network.add_node(5, str(EDS))
