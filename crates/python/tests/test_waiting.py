"""Blocking waits release the GIL and can be interrupted; the awaitable twins run on asyncio."""

from __future__ import annotations

import asyncio
import os
import signal
import threading
from typing import Any

import pytest

import canola
from conftest import EDS


@pytest.fixture
def realtime() -> tuple[canola.Network, canola.MemoryBus]:
    bus = canola.MemoryBus(realtime=True)
    bus.attach(canola.SimDevice.from_eds(str(EDS), 5))
    return canola.Network(bus), bus


def test_a_blocking_wait_lets_other_python_threads_run(
    realtime: tuple[canola.Network, canola.MemoryBus],
) -> None:
    net, _ = realtime
    node = net.add_node(5, str(EDS))
    assert node.nmt.wait_for_heartbeat(5) == "PRE-OPERATIONAL"
    # The reset comes from another Python thread while this one waits for the boot-up it
    # causes: were the GIL held during the wait, the thread could not run and the wait would
    # time out.
    resetter = threading.Timer(0.2, lambda: setattr(node.nmt, "state", "RESET"))
    resetter.start()
    try:
        node.nmt.wait_for_bootup(30)
    finally:
        resetter.join()
        net.disconnect()


@pytest.mark.skipif(threading.current_thread() is not threading.main_thread(), reason="signals")
def test_ctrl_c_interrupts_a_blocking_wait(
    realtime: tuple[canola.Network, canola.MemoryBus],
) -> None:
    net, _ = realtime
    absent = net.add_node(9, str(EDS))
    interrupter = threading.Timer(0.2, lambda: os.kill(os.getpid(), signal.SIGINT))
    interrupter.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            absent.nmt.wait_for_bootup(60)
        # The network goes on working after the interrupt.
        assert net.add_node(5, str(EDS)).sdo[0x1017].raw == 500
    finally:
        interrupter.join()
        net.disconnect()


@pytest.mark.skipif(threading.current_thread() is not threading.main_thread(), reason="signals")
def test_ctrl_c_interrupts_the_pdo_and_emcy_waits(
    realtime: tuple[canola.Network, canola.MemoryBus],
) -> None:
    net, _ = realtime
    node = net.add_node(5, str(EDS))
    node.tpdo.read()  # pre-operational: no TPDO comes, and no EMCY
    try:
        for wait in (lambda: node.tpdo[1].wait_for_reception(60), lambda: node.emcy.wait(None, 60)):
            interrupter = threading.Timer(0.2, lambda: os.kill(os.getpid(), signal.SIGINT))
            interrupter.start()
            try:
                with pytest.raises(KeyboardInterrupt):
                    wait()
            finally:
                interrupter.join()
    finally:
        net.disconnect()


def test_awaitable_twins(node: canola.RemoteNode) -> None:
    async def main() -> None:
        var = node.sdo["Producer heartbeat time"]
        assert await var.aget_raw() == 500
        await var.aset_raw(150)
        assert await node.sdo.aupload(0x1017, 0) == b"\x96\x00"
        await node.sdo.adownload(0x1017, 0, b"\xc8\x00")
        assert var.raw == 200
        with pytest.raises(canola.SdoAbortedError) as caught:
            await node.sdo.aupload(0x2FFF, 0)
        assert caught.value.code == 0x06020000 and "node 5" in str(caught.value)

    asyncio.run(main())


def test_awaitables_overlap_on_the_bus() -> None:
    bus = canola.MemoryBus()
    for id in range(1, 9):
        bus.attach(canola.SimDevice.from_eds(str(EDS), id))
    with canola.Network(bus) as net:
        nodes = [net.add_node(id, str(EDS)) for id in range(1, 9)]

        async def main() -> list[Any]:
            return await asyncio.gather(*(n.sdo[0x1018][1].aget_raw() for n in nodes))

        assert asyncio.run(main()) == [0x39] * 8


def test_awaitable_twins_on_a_real_time_bus(
    realtime: tuple[canola.Network, canola.MemoryBus],
) -> None:
    net, _ = realtime
    node = net.add_node(5, str(EDS))
    absent = net.add_node(9, str(EDS))

    async def main() -> None:
        assert await node.sdo[0x1017].aget_raw() == 500
        await node.sdo[0x1017].aset_raw(120)
        assert await node.sdo.aupload(0x1017, 0) == b"\x78\x00"
        with pytest.raises(canola.SdoCommunicationError, match="node 9"):
            await absent.sdo.aupload(0x1000, 0)

    try:
        asyncio.run(main())
    finally:
        net.disconnect()
