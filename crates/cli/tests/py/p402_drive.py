"""python-canopen 2.4.1's BaseNode402 as the master of the simulated servo (tests/drive_python.rs).

The drive is `canopen simulate eds/cia402-servo.eds --node-id 5` on python-can's udp_multicast
bus. BaseNode402 walks the state machine, switches modes, makes a profile-position move, homes,
quick-stops and resets a fault, with its own code (controlword and mode by RPDO1, statusword and
mode display from TPDO1, as it finds them in the drive's PDO configuration).

Arguments: GROUP PORT EDS (the UDP bus), or `socketcan IFACE EDS` (the rig on vcan0,
tests/vcan/p402_python.sh). Prints one line per check: `NAME value`; python-canopen's exceptions
are printed as `NAME raised: text`.
"""

import sys
import time

import canopen
from canopen.profiles.p402 import BaseNode402

net = canopen.Network()
if sys.argv[1] == "socketcan":
    eds = sys.argv[3]
    net.connect(interface="socketcan", channel=sys.argv[2])
else:
    group, port, eds = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    net.connect(interface="udp_multicast", channel=group, port=port)
node = BaseNode402(5, eds)
net.add_node(node)


def say(*words):
    print(" ".join(str(w) for w in words), flush=True)


def wait_sw(pred, secs):
    end = time.monotonic() + secs
    while time.monotonic() < end:
        if pred(node.statusword):
            return True
        time.sleep(0.005)
    return False


def attempt(name, f):
    try:
        say(name, f())
    except Exception as e:  # python-canopen raises RuntimeError/ValueError on timeouts
        say(name, "raised:", type(e).__name__, e)


node.nmt.state = "PRE-OPERATIONAL"
time.sleep(0.1)
node.setup_402_state_machine()
node.nmt.state = "OPERATIONAL"
time.sleep(0.3)
say("INITIAL", node.state.replace(" ", "_"))

for target in ("READY TO SWITCH ON", "SWITCHED ON"):
    node.state = target
    say("STATE", node.state.replace(" ", "_"))

# python-canopen bug: the bus hands python-canopen its own RPDO frames back (python-can's
# udp_multicast does, as a virtual CAN interface with own-message reception does); the RPDO
# map takes them for receptions, sets its `period` from two of them, and from then on counts as
# periodic, so BaseNode402's controlword setter stops transmitting (it expects a periodic task
# to send it). Shown, then worked around: the RPDO maps stop listening to their own COB-IDs.
rpdo1 = node.rpdo_pointers[0x6040].pdo_parent
say("ECHO_PERIODIC", rpdo1.is_periodic)
for m in node.rpdo.map.values():
    net.unsubscribe(m.cob_id, m.on_message)
    m.period = None

node.state = "OPERATION ENABLED"
say("STATE", node.state.replace(" ", "_"))

for mode in ("PROFILED VELOCITY", "PROFILED POSITION"):
    node.op_mode = mode
    say("MODE", node.op_mode.replace(" ", "_"))

# Profile position: target, then the new set-point handshake (bit 4 up, ack on bit 12).
node.sdo[0x6081].raw = 20000
node.sdo[0x607A].raw = 3000
node.controlword = 0x1F
say("ACK", wait_sw(lambda sw: sw & 0x1000, 1.0))
node.controlword = 0x0F
say("REACHED", wait_sw(lambda sw: sw & 0x0400 and not sw & 0x1000, 5.0))
say("POSITION", node.sdo[0x6064].raw)

# Homing on the home switch (method 19).
node.sdo[0x6098].raw = 19
say("HOMED", node.homing(timeout=10))
say("HOMED_POSITION", node.sdo[0x6064].raw)
node.controlword = 0x0F  # homing() leaves the start bit set

# Quick stop with 0x605A = 2: the drive passes through quick stop active to switch on disabled.
attempt("QUICKSTOP", lambda: setattr(node, "state", "QUICK STOP ACTIVE"))
time.sleep(0.3)
say("AFTER_QUICKSTOP", node.state.replace(" ", "_"))

# A fault: a move beyond the positive limit switch (200000 counts).
node.state = "OPERATION ENABLED"
node.op_mode = "PROFILED POSITION"
node.sdo[0x6081].raw = 200000
node.sdo[0x607A].raw = 250000
node.controlword = 0x1F
node.controlword = 0x0F
say("FAULTED", wait_sw(lambda sw: sw & 0x4F == 0x08, 5.0))
say("ERROR_CODE", hex(node.sdo[0x603F].raw))
time.sleep(0.1)
say("EMCY", " ".join(hex(e.code) for e in node.emcy.log))
attempt("RESET", node.reset_from_fault)
say("AFTER_RESET", node.state.replace(" ", "_"))
net.disconnect()
