"""Dumps python-canopen's own CiA 402 tables (canopen.profiles.p402) as text lines, for
tests/python_p402.rs. Only reads the library's class attributes and helpers; no bus."""
from canopen.profiles.p402 import Homing, OperationMode, State402

names = list(State402.SW_MASK)
print("names " + "|".join(names))
for name, (mask, value) in State402.SW_MASK.items():
    print(f"mask {name}|{mask}|{value}")

# The state BaseNode402.state reports for every statusword: first SW_MASK entry that matches.
codes = []
for sw in range(0x10000):
    found = "-"
    for i, (name, (mask, value)) in enumerate(State402.SW_MASK.items()):
        if sw & mask == value:
            found = chr(ord("a") + i)
            break
    codes.append(found)
print("states " + "".join(codes))

for name, cw in State402.CW_COMMANDS_CODE.items():
    print(f"command {name}|{cw}")
for (a, b), cw in State402.TRANSITIONTABLE.items():
    print(f"transition {a}|{b}|{cw}")

# BaseNode402.state's setter walk (_next_state / _change_state) without a bus: the states it
# passes and the controlword of each hop.
targets = ["SWITCH ON DISABLED", "READY TO SWITCH ON", "SWITCHED ON", "OPERATION ENABLED", "QUICK STOP ACTIVE"]
for start in names:
    for target in targets:
        at, words = start, []
        for _ in range(10):
            if at == target:
                break
            nxt = target if (at, target) in State402.TRANSITIONTABLE else State402.next_state_indirect(at)
            cw = State402.TRANSITIONTABLE.get((at, nxt))
            words.append("x" if cw is None else str(cw))
            at = nxt
        print(f"path {start}|{target}|{' '.join(words)}|{at}")

for name, (mask, value) in Homing.STATES.items():
    print(f"homing {name}|{mask}|{value}")
for code, name in OperationMode.CODE2NAME.items():
    print(f"mode {code}|{name}|{OperationMode.SUPPORTED[name]}")
