#!/usr/bin/env python3
"""Checks a DeviceNet capture (candump -L log) with Wireshark's DeviceNet dissector against the
devicenet crate's own decoding, field by field.

    devicenet_tshark.py LOG CANDUMP_FIELDS

tshark reads the candump log itself (wiretap's candump reader) and, with `-d
can.subdissector=devicenet`, hands every frame to its DeviceNet dissector. The dissector
decodes the identifier (message group, message ID, MAC ID) of every frame and the fields of the
Duplicate MAC ID check message; group 1 and group 2 messages 0..6 (poll I/O, the Predefined
Master/Slave Connection Set's explicit and unconnected messages) it shows as raw data only, so
for those the data bytes are compared. CANDUMP_FIELDS is the crate's example that prints its
decoding of the same log.
"""
import subprocess
import sys

log, ours_bin = sys.argv[1], sys.argv[2]
FIELDS = [
    "can.id",
    "devicenet.grp_msg1.id",
    "devicenet.grp_msg2.id",
    "devicenet.grp_msg3.id",
    "devicenet.src_mac_id",
    "devicenet.data",
    "devicenet.dup_mac_id.rr",
    "devicenet.dup_mac_id.physical_port_number",
    "devicenet.dup_mac_id.vendor",
    "devicenet.dup_mac_id.serial_number",
]
cmd = ["tshark", "-r", log, "-d", "can.subdissector=devicenet", "-T", "fields", "-E", "separator=\t"]
for f in FIELDS:
    cmd += ["-e", f]
theirs = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout.splitlines()
ours = subprocess.run([ours_bin, log], check=True, capture_output=True, text=True).stdout.splitlines()
print(f"tshark {len(theirs)} frames, devicenet crate {len(ours)} frames")
assert len(theirs) == len(ours) and ours, (len(theirs), len(ours))


def num(s):
    s = s.strip()
    if s in ("", "<MISSING>"):
        return None
    return int(s, 16) if s.startswith("0x") else int(s)


kinds = {}
compared = 0
for n, (t, o) in enumerate(zip(theirs, ours), 1):
    t = t.split("\t")
    o = o.split("\t")
    can_id, g1, g2, g3, mac, data, rr, port, vendor, serial = (t + [""] * 10)[:10]
    o_id, o_group, o_msg, o_mac, o_data, o_rr, o_port, o_vendor, o_serial, text = o
    where = f"frame {n} ({text})"
    assert num(can_id) == int(o_id), (where, can_id, o_id)
    msg = {"1": g1, "2": g2, "3": g3}.get(o_group)
    assert msg is not None and num(msg) == int(o_msg), (where, "message ID", t, o)
    assert num(mac) == int(o_mac), (where, "MAC ID", mac, o_mac)
    if o_rr:
        # Duplicate MAC ID check: every field.
        assert num(rr) == int(o_rr), (where, "R/R", rr, o_rr)
        assert num(port) == int(o_port), (where, "port", port, o_port)
        assert num(vendor) == int(o_vendor), (where, "vendor", vendor, o_vendor)
        assert num(serial) == int(o_serial), (where, "serial", serial, o_serial)
        compared += 4
    else:
        assert (data if data != "<MISSING>" else "") == o_data, (where, "data", data, o_data)
        compared += 1
    compared += 3
    kind = text.split(":")[0]
    kinds[kind] = kinds.get(kind, 0) + 1

for k, c in sorted(kinds.items()):
    print(f"  {c:6}  {k}")
print(f"devicenet_tshark: {len(ours)} frames, {compared} fields agree with Wireshark's DeviceNet dissector")
# The capture must hold the whole story: both Duplicate MAC ID checks, allocation, explicit
# requests and responses, and polled I/O both ways.
for needed in [
    "DeviceNet duplicate MAC ID check of MAC 0",
    "DeviceNet duplicate MAC ID check of MAC 63",
    "DeviceNet unconnected explicit request to MAC 63",
    "DeviceNet explicit request to MAC 63",
    "DeviceNet explicit response from MAC 63",
    "DeviceNet poll command to MAC 63",
    "DeviceNet poll response from MAC 63",
]:
    assert kinds.get(needed, 0) > 0, f"no {needed!r} in the capture"
