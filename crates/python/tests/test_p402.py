"""CiA 402 (canola.BaseNode402, python-canopen's BaseNode402) against the simulated servo drive."""

from __future__ import annotations

import os
import signal
import threading
import time
from typing import Iterator

import pytest

import canola
from conftest import EDS_DIR

SERVO = str(EDS_DIR / "cia402-servo.eds")


@pytest.fixture
def sim() -> canola.SimDevice:
    """The simulated CiA 402 drive of node 3."""
    return canola.SimDevice.cia402_drive(SERVO, 3)


@pytest.fixture
def drive(sim: canola.SimDevice) -> Iterator[canola.BaseNode402]:
    """Node 3 as a BaseNode402 on a virtual-clock bus with the simulated drive."""
    bus = canola.MemoryBus()
    bus.attach(sim)
    with canola.Network(bus) as net:
        node = net.add_node(canola.BaseNode402(3, SERVO))
        node.setup_402_state_machine()
        yield node


def test_add_node_gives_the_402_node_back(drive: canola.BaseNode402) -> None:
    assert isinstance(drive, canola.RemoteNode)
    assert drive.id == 3
    assert repr(drive) == "<canola.BaseNode402 3>"
    # A RemoteNode still: SDO by name and index.
    assert drive.sdo[0x6041].raw == drive.statusword


def test_state_machine_walks_to_each_state(drive: canola.BaseNode402) -> None:
    drive.state = "SWITCH ON DISABLED"
    assert drive.state == "SWITCH ON DISABLED"
    for target in ("READY TO SWITCH ON", "SWITCHED ON", "OPERATION ENABLED"):
        drive.state = target
        assert drive.state == target
    assert drive.statusword & 0x6F == 0x27
    drive.sdo[0x605A].raw = 6  # quick stop option: stay in quick stop active
    drive.state = "QUICK STOP ACTIVE"
    assert drive.state == "QUICK STOP ACTIVE"
    # Indirect: from quick stop active back up (transition 16 or through switch on disabled).
    drive.state = "OPERATION ENABLED"
    assert drive.state == "OPERATION ENABLED"
    drive.state = "SWITCH ON DISABLED"
    assert drive.state == "SWITCH ON DISABLED"


def test_setup_reads_the_pdo_configuration(drive: canola.BaseNode402) -> None:
    # The fixture ran setup_402_state_machine(): the drive's PDOs are known.
    assert drive.tpdo[1].cob_id == 0x180 + 3
    assert any(var.index == 0x6041 for var in drive.tpdo[1])
    drive.setup_pdos(upload=False)


def test_states_only_the_drive_enters_are_a_value_error(drive: canola.BaseNode402) -> None:
    for name in ("FAULT", "NOT READY TO SWITCH ON", "FAULT REACTION ACTIVE"):
        with pytest.raises(ValueError, match="cannot be entered programmatically"):
            drive.state = name
    with pytest.raises(ValueError, match="unknown CiA 402 state"):
        drive.state = "FLYING"


def test_controlword_is_write_only_and_drives_the_state(drive: canola.BaseNode402) -> None:
    with pytest.raises(RuntimeError, match="write-only"):
        drive.controlword
    drive.state = "SWITCH ON DISABLED"
    drive.controlword = 0x06  # shutdown: transition 2
    assert drive.check_statusword() & 0x6F == 0x21
    assert drive.state == "READY TO SWITCH ON"


def test_op_mode_round_trip_and_support(drive: canola.BaseNode402) -> None:
    assert drive.op_mode == "NO MODE"
    drive.op_mode = "PROFILED VELOCITY"
    assert drive.op_mode == "PROFILED VELOCITY"
    assert drive.sdo[0x6061].raw == 3
    drive.op_mode = "CYCLIC SYNCHRONOUS POSITION"
    assert drive.op_mode == "CYCLIC SYNCHRONOUS POSITION"
    # Selecting a mode does not change the power state (python-canopen #244).
    assert drive.state == "SWITCH ON DISABLED"
    assert drive.is_op_mode_supported("HOMING")
    assert drive.is_op_mode_supported("PROFILED POSITION")
    assert not drive.is_op_mode_supported("VELOCITY")  # 0x6502 = 0x03ED
    with pytest.raises(ValueError, match="unknown operation mode"):
        drive.op_mode = "WARP"


def test_a_mode_the_drive_refuses_is_its_sdo_abort(drive: canola.BaseNode402) -> None:
    with pytest.raises(canola.SdoAbortedError) as err:
        drive.op_mode = "OPEN LOOP VECTOR MODE"
    assert err.value.code == 0x06090030


def test_homing_then_is_homed(drive: canola.BaseNode402) -> None:
    drive.op_mode = "PROFILED POSITION"
    assert not drive.is_homed(restore_op_mode=True)
    assert drive.op_mode == "PROFILED POSITION"
    drive.sdo[0x6098].raw = 19  # positive home switch: a real homing run
    assert drive.homing(timeout=30) is True
    # Homing enables the drive, as python-canopen's does.
    assert drive.state == "OPERATION ENABLED"
    assert drive.op_mode == "HOMING"
    assert drive.is_homed()
    drive.op_mode = "PROFILED VELOCITY"
    assert drive.homing(restore_op_mode=True)
    assert drive.op_mode == "PROFILED VELOCITY"


def test_a_failed_homing_raises_with_the_statusword(drive: canola.BaseNode402) -> None:
    # Method 0 is no homing method: the drive reports a homing error (statusword bit 13),
    # which python-canopen would log, returning False.
    drive.sdo[0x6098].raw = 0
    with pytest.raises(canola.Drive402Error, match="homing failed") as err:
        drive.homing()
    assert isinstance(err.value, RuntimeError)
    assert err.value.statusword is not None and err.value.statusword & 0x2000
    assert err.value.state == "OPERATION ENABLED"


def test_fault_then_reset_from_fault(sim: canola.SimDevice, drive: canola.BaseNode402) -> None:
    drive.state = "OPERATION ENABLED"
    sim.inject_fault(0x8611)
    assert drive.state == "FAULT"
    assert drive.is_faulted()
    assert drive.sdo[0x603F].raw == 0x8611
    drive.reset_from_fault()
    assert drive.state == "OPERATION ENABLED"
    assert not drive.is_faulted()
    # Not in fault: left as it is.
    drive.reset_from_fault()
    assert drive.state == "OPERATION ENABLED"


def test_inject_fault_needs_a_drive() -> None:
    with pytest.raises(ValueError, match="not a cia402_drive"):
        canola.SimDevice.from_eds(SERVO, 4).inject_fault(0x8611)


@pytest.mark.skipif(threading.current_thread() is not threading.main_thread(), reason="signals")
def test_ctrl_c_during_homing_quick_stops_the_drive() -> None:
    bus = canola.MemoryBus(realtime=True)
    bus.attach(canola.SimDevice.cia402_drive(SERVO, 3))
    with canola.Network(bus) as net:
        drive = net.add_node(canola.BaseNode402(3, SERVO))
        drive.sdo[0x605A].raw = 6  # quick stop option: stay in quick stop active
        drive.sdo[0x6098].raw = 17  # the negative limit switch, far away: a long run
        interrupter = threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT))
        interrupter.start()
        try:
            with pytest.raises(KeyboardInterrupt):
                drive.homing(timeout=0)
        finally:
            interrupter.join()
        deadline = time.monotonic() + 2.0
        while drive.state != "QUICK STOP ACTIVE" and time.monotonic() < deadline:
            time.sleep(0.01)
        assert drive.state == "QUICK STOP ACTIVE"


def test_timeouts_in_python_canopen_s_names(drive: canola.BaseNode402) -> None:
    assert drive.TIMEOUT_SWITCH_STATE_SINGLE == 1.0
    assert drive.TIMEOUT_SWITCH_OP_MODE == 1.0
    assert drive.TIMEOUT_HOMING_DEFAULT == 30
    drive.TIMEOUT_SWITCH_OP_MODE = 0.25
    assert drive.TIMEOUT_SWITCH_OP_MODE == 0.25
    drive.TIMEOUT_RESET_FAULT = 0.5
    assert drive.TIMEOUT_SWITCH_STATE_SINGLE == 0.5
    drive.TIMEOUT_SWITCH_STATE_FINAL = 2.0  # accepted; each step has the single limit
    assert drive.TIMEOUT_SWITCH_STATE_FINAL == 0.5
    with pytest.raises(ValueError):
        drive.TIMEOUT_SWITCH_OP_MODE = -1
    # A homing limit too short for the run: the timeout names what was awaited.
    drive.TIMEOUT_HOMING_DEFAULT = 0.05
    drive.sdo[0x6098].raw = 17  # the negative limit switch, far away
    with pytest.raises(canola.Drive402Error, match="timed out") as err:
        drive.homing()
    assert err.value.state == "OPERATION ENABLED"
