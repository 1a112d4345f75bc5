#!/usr/bin/env python3
"""Writes the committed seed corpus of every fuzz target to fuzz/seeds/TARGET/.

The seeds are valid, typical inputs in each target's input layout (CiA 301 example frames,
CiA 305 LSS requests, candump lines, CiA 309-3 command lines, the first kilobytes of this
repository's own EDS files, ...), so a short CI run starts from inputs that reach deep paths
instead of from nothing. The smoke stage of scripts/test-all and scripts/fuzz-long read them
beside the persisted corpus. Rerun after changing a target's input layout:

    python3 fuzz/make-seeds.py
"""

import os
import re
import shutil
import struct

ROOT = os.path.dirname(os.path.abspath(__file__))
SEEDS = os.path.join(ROOT, "seeds")
REPO = os.path.dirname(ROOT)


def u16(v):
    return struct.pack("<H", v)


def u32(v):
    return struct.pack("<I", v)


def sdo(cs, index, sub, data=b""):
    """An 8-byte SDO frame: command byte, multiplexer, data padded to 4 bytes."""
    return bytes([cs]) + u16(index) + bytes([sub]) + (data + bytes(4))[:4]


# SDO client requests (CiA 301 §7.2.4.3): what a server decodes.
CLIENT_REQUESTS = [
    sdo(0x40, 0x1000, 0),  # initiate upload
    sdo(0x2B, 0x1017, 0, u16(1000)),  # expedited download, 2 bytes
    sdo(0x23, 0x1400, 1, u32(0x205)),  # expedited download, 4 bytes
    sdo(0x21, 0x2001, 0, u32(11)),  # segmented download, size 11
    bytes([0x00]) + b"Hello, ",  # download segment, toggle 0
    bytes([0x13]) + b"CiA" + bytes(4),  # last segment, toggle 1, 4 bytes unused
    bytes([0x60]) + bytes(7),  # upload segment request
    sdo(0xA4, 0x1008, 0, bytes([0x7F, 0x00])),  # block upload initiate, CRC, blksize 127
    bytes([0xA3]) + bytes(7),  # block upload start
    bytes([0xA2, 0x05, 0x7F]) + bytes(5),  # block ack, seqno 5, blksize 127
    sdo(0xC6, 0x2001, 0, u32(20)),  # block download initiate, CRC, size
    bytes([0xC9, 0x34, 0x12]) + bytes(5),  # block download end, 2 bytes unused, CRC
    sdo(0x80, 0x1000, 0, u32(0x05040000)),  # abort: SDO protocol timed out
]

# SDO server responses: what a client decodes.
SERVER_RESPONSES = [
    sdo(0x43, 0x1000, 0, u32(0x00020191)),  # expedited upload, 4 bytes
    sdo(0x4B, 0x1017, 0, u16(1000)),  # expedited upload, 2 bytes
    sdo(0x41, 0x1008, 0, u32(20)),  # segmented upload, size 20
    bytes([0x00]) + b"Buerker",  # upload segment
    bytes([0x1B]) + b"t" + bytes(6),  # last segment, 6 unused
    sdo(0x60, 0x1017, 0),  # download acknowledged
    bytes([0x20]) + bytes(7),  # download segment acknowledged
    sdo(0xC6, 0x1008, 0, u32(20)),  # block upload initiate response, CRC, size
    bytes([0xA4, 0x7F]) + bytes(6),  # block download initiate response
    bytes([0x01]) + b"Block 1",  # block segment 1
    bytes([0x81]) + b"Block 2",  # last block segment 1
    bytes([0xA2, 0x7F, 0x7F]) + bytes(5),  # block ack
    bytes([0xC5, 0x34, 0x12]) + bytes(5),  # block upload end
    sdo(0x80, 0x6000, 1, u32(0x06020000)),  # abort: object does not exist
]

def usdo(dst, cs, session, rest=b""):
    """A USDO frame (CiA 1301, SOFA-CANopenFD layout) padded with zeros to a CAN FD length."""
    frame = bytes([dst, cs, session]) + rest
    for size in (0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64):
        if size >= len(frame):
            return frame + bytes(size - len(frame))
    return frame


def usdo_mux(index, sub):
    return bytes([sub]) + u16(index)


SEGMENT = bytes(range(60))

# USDO frames of every kind, client node 1, server node 5.
USDO_FRAMES = [
    usdo(5, 0x01, 7, usdo_mux(0x2000, 1) + bytes([0x07, 4]) + u32(0x12345678)),  # expedited write
    usdo(1, 0x21, 7, usdo_mux(0x2000, 1)),  # expedited write done
    usdo(5, 0x11, 8, usdo_mux(0x1018, 1)),  # read
    usdo(1, 0x31, 8, usdo_mux(0x1018, 1) + bytes([0x0F, 2, 0xAA, 0xBB])),  # expedited value
    usdo(5, 0x02, 9, usdo_mux(0x2100, 0) + bytes([0x0F, 0]) + u32(100)),  # segmented write
    usdo(1, 0x22, 9, usdo_mux(0x2100, 0)),  # accepted
    usdo(5, 0x03, 9, bytes([0]) + SEGMENT),  # segment 0
    usdo(1, 0x23, 9, bytes([0])),  # segment 0 confirmed
    usdo(5, 0x04, 9, bytes([40]) + SEGMENT[:40]),  # last 40 bytes
    usdo(1, 0x24, 9),  # write done
    usdo(1, 0x32, 10, usdo_mux(0x1008, 0) + bytes([0x09, 0]) + u32(70)),  # segmented value
    usdo(5, 0x13, 10, bytes([0])),  # segment 0, please
    usdo(1, 0x33, 10, bytes([0]) + SEGMENT),  # segment 0
    usdo(1, 0x34, 10, bytes([10]) + SEGMENT[:10]),  # last 10 bytes
    usdo(1, 0x7F, 11, usdo_mux(0x6000, 0) + bytes([0x33])),  # abort: no such object
]

NMT_FRAMES = [
    bytes([0x01, 0x00]),  # start all
    bytes([0x80, 0x05]),  # node 5 to pre-operational
    bytes([0x81, 0x05]),  # reset node 5
    bytes([0x82, 0x00]),  # reset communication, all
    bytes([0x00]),  # boot-up
    bytes([0x05]),  # heartbeat operational
    bytes([0x7F]),  # heartbeat pre-operational
    bytes([0x85]),  # guarding answer, toggle set, operational
    bytes([0x10, 0x81, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00]),  # EMCY: CAN overrun
    bytes([0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]),  # EMCY: error reset
    bytes([0x00, 0x50, 0x80, 0x01, 0x02, 0x03, 0x04, 0x05]),  # EMCY: device hardware
]


def lss(cs, payload=b""):
    return (bytes([cs]) + payload + bytes(7))[:8]


# CiA 305 requests and responses.
LSS_FRAMES = [
    lss(0x04, b"\x01"),  # switch state global: configuration
    lss(0x04, b"\x00"),  # switch state global: waiting
    lss(0x40, u32(0x0000006C)),  # switch selective: vendor-ID (Buerkert 0x6C)
    lss(0x41, u32(0x00001234)),  # product code
    lss(0x42, u32(0x00000002)),  # revision
    lss(0x43, u32(0x0000CAFE)),  # serial
    lss(0x44),  # selective switch response
    lss(0x11, b"\x05"),  # configure node-ID 5
    lss(0x11, b"\x00"),  # response: success
    lss(0x13, b"\x00\x03"),  # configure bit timing: table 0, 500 kbit/s
    lss(0x15, u16(100)),  # activate bit timing, delay 100 ms
    lss(0x17),  # store configuration
    lss(0x5A),  # inquire vendor-ID
    lss(0x5E),  # inquire node-ID
    lss(0x4C),  # identify non-configured remote slave
    lss(0x50),  # identify slave (response)
    lss(0x51, u32(0) + bytes([0x80, 0x00, 0x00])),  # fastscan: reset, bit 128
    lss(0x51, u32(0x6C) + bytes([0x00, 0x00, 0x00])),  # fastscan: vendor, all bits checked
]

CANDUMP = [
    b"(1700000000.000000) vcan0 705#00\n(1700000000.000100) vcan0 605#4000100000000000\n",
    b"(1700000000.001000) can0 585#4300100091010200\n(1700000000.002000) can0 080#\n",
    b"vcan0 1FFFFFFF#DEADBEEF\nvcan0 123#R\nvcan0 123#R3\n",
    b"(0.000001) vcan0 123##1112233445566778899AABBCCDDEEFF\n",
    b"(1.5) can1 7E5#0401000000000000 R\n# comment\n\n",
    # candump -8: a raw DLC above 8 after 8 bytes (kept), and ones that do not fit.
    b"(2.000000) can0 123#1122334455667788_C\n(2.1) can0 12345678#R8_9\n"
    b"(2.2) can0 123#1122334455667788_8\n(2.3) can0 123#11_C\n",
]


def msgpack(obj):
    """The msgpack subset python-can's udp_multicast messages use."""
    if obj is None:
        return b"\xc0"
    if obj is True:
        return b"\xc3"
    if obj is False:
        return b"\xc2"
    if isinstance(obj, float):
        return b"\xcb" + struct.pack(">d", obj)
    if isinstance(obj, int):
        if 0 <= obj < 128:
            return bytes([obj])
        return b"\xce" + struct.pack(">I", obj)
    if isinstance(obj, str):
        b = obj.encode()
        return bytes([0xA0 | len(b)]) + b
    if isinstance(obj, bytes):
        return b"\xc4" + bytes([len(obj)]) + obj
    if isinstance(obj, dict):
        out = bytes([0x80 | len(obj)])
        for k, v in obj.items():
            out += msgpack(k) + msgpack(v)
        return out
    raise TypeError(obj)


def udp_message(can_id, data, extended=False, remote=False, fd=False):
    return msgpack(
        {
            "timestamp": 1700000000.25,
            "arbitration_id": can_id,
            "is_extended_id": extended,
            "is_remote_frame": remote,
            "is_error_frame": False,
            "channel": None,
            "dlc": len(data),
            "data": data,
            "is_fd": fd,
            "bitrate_switch": False,
            "error_state_indicator": False,
        }
    )


UDP = [
    udp_message(0x605, sdo(0x40, 0x1000, 0)),
    udp_message(0x705, b"\x00"),
    udp_message(0x1ABCDE, b"\x01\x02", extended=True),
    udp_message(0x705, b"", remote=True),
]

GATEWAY = [
    b"[1] 5 read 0x1017 0 u16\n",
    b"[2] 5 write 0x1017 0 u16 1000\r\n",
    b"[3] 1 5 r 0x1008 0 vs\n[4] 5 w 0x2001 0 vs \"Hello world\"\n",
    b"[5] 5 start\n[6] 5 preop\n[7] 0 reset comm\n[8] 5 reset node\n",
    b"[9] set network 1\n[10] set node 5\n[11] set sdo_timeout 500\n[12] set sdo_block 1\n",
    b"[13] lss_switch_glob 1\n[14] lss_set_node 7\n[15] lss_store\n[16] lss_inquire_addr\n",
    b"[17] 5 w 0x1010 1 u32 0x65766173\n[18] help\n[19] info version\n# a comment\n",
    b"[20] 5 r 0x1018 1 x32\n[21] 5 w 0x2010 0 os AQID\n[22] 5 r 0x6000 1 i8\n",
]

BURKERT = [u32(v) for v in (0, 1, 0x0000_0064, 0x8000_0000, 0xFFFF_FFFF, 0x0001_0203)]


def frames(*items):
    return b"".join(items)


# Mapping-count byte, raw mapping entries (index << 16 | sub << 8 | bits), then frame data.
PDO = [
    bytes([2]) + u32(0x6000_0110) + u32(0x6000_0210) + bytes([1, 0, 2, 0]),
    bytes([4]) + u32(0x6000_0108) + u32(0x6000_0208) + u32(0x6401_0110) + u32(0x2000_0020)
    + bytes(8),
    bytes([3]) + u32(0x6000_0101) + u32(0x0005_0007) + u32(0x6000_0208) + bytes([0x81, 0x7F]),
    bytes([1]) + u32(0x1018_0120) + u32(0x6C),
]

# Selector (data-type pick) then EDS value text.
OD_VALUES = [bytes([s]) + t for s, t in [
    (0, b"1"), (1, b"-128"), (2, b"0x7FFF"), (3, b"$NODEID+0x180"), (4, b"0x12345678"),
    (5, b"255"), (6, b"65535"), (7, b"0xFFFFFFFF"), (8, b"3.25"), (9, b"Visible text"),
    (10, b"0102030A"), (11, b"-9223372036854775808"), (12, b"18446744073709551615"),
    (13, b"1e-3"), (14, b"0"), (15, b"$NODEID"),
]]

GEMU = [
    bytes([0x01, 0x00, 0x00, 0x00, 0x00]),
    bytes([0x00, 0x10, 0x27, 0x00, 0x00, 0x00, 0x00, 0x00]),
    bytes(range(13)),
    bytes([0x02, 0xE8, 0x03]),
]

# Two identifier bytes (big-endian, 11 bits) then the data.
DEVICENET = [
    bytes([0x05, 0x3C]) + bytes([0x3F, 0x4B, 0x03, 0x01, 0x01, 0x00]),  # group 2 allocate
    bytes([0x05, 0x3B]) + bytes([0x3F, 0x0E, 0x01, 0x01, 0x01]),  # explicit request
    bytes([0x04, 0x7B]) + bytes([0x3F, 0x8E, 0x20, 0x00]),  # explicit response
    bytes([0x05, 0x3D]) + bytes([0x01, 0x00]),  # poll command
    bytes([0x05, 0x3F]) + bytes([0x00, 0x10, 0x01, 0xA0, 0x86, 0x01, 0x00]),  # dup MAC check
    bytes([0x05, 0x3B]) + bytes([0x3F, 0x80, 0x0E, 0x01, 0x01, 0x01, 0x07, 0x00]),  # fragment
]

# Chunks of [selector, time step, dlc, up to 8 data bytes].
DEVICENET_SEQ = [
    frames(bytes([1, 10, 6, 0x3F, 0x4B, 0x03, 0x01, 0x03, 0x00, 0, 0]),
           bytes([2, 10, 2, 0x01, 0x00, 0, 0, 0, 0, 0, 0])),
    frames(bytes([0, 10, 5, 0x3F, 0x0E, 0x01, 0x01, 0x01, 0, 0, 0]),
           bytes([1, 5, 4, 0x3F, 0x8E, 0x20, 0x00, 0, 0, 0, 0])),
    frames(bytes([3, 100, 7, 0x00, 0x10, 0x01, 0xA0, 0x86, 0x01, 0x00, 0])),
]

# Kind byte, then chunks of [selector, time step, 8 frame bytes].
LSS_SEQ = [
    bytes([1]) + frames(bytes([0, 1]) + lss(0x4C), bytes([1, 1]) + lss(0x4F),
                        bytes([0, 1]) + lss(0x51, u32(0) + bytes([0x80, 0, 0]))),
    bytes([0]) + frames(bytes([1, 10]) + lss(0x4F), bytes([1, 10]) + lss(0x11, b"\x00"),
                        bytes([1, 10]) + lss(0x17, b"\x00")),
]


BUS_TOML = [
    b'[[slave]]\nnode_id = 5\ndcf = "valve.dcf"\nmandatory = true\n',
    b'[master]\nnode_id = 1\nsdo_timeout_ms = 100\nboot_timeout_ms = 300\nstart_all = true\n\n'
    b'[[slave]]\nnode_id = 5\ndcf = "valve.dcf"\nmandatory = true\n[slave.identity]\n'
    b'vendor_id = 0x39\nproduct_code = 0x1234\n\n[[slave]]\nnode_id = 7\neds = "valve.dcf"\n'
    b'[slave.values]\n"0x2000" = 321\n"0x1017" = 50\n',
    b'[[slave]]\nnode_id = 6\ndcf = "valve-boot.dcf"\nkeep_alive = true\n[slave.software]\n'
    b'date = "2026-03-01"\ntime = "10:00:00.000"\nupdate = true\nprogram = "valve-v2.bin"\n',
    b'master_dcf = "master.dcf"\n',
]


def repo_file(*parts):
    with open(os.path.join(REPO, *parts), "rb") as f:
        return f.read()


def eds_heads():
    """The first two kilobytes of this repository's own EDS files (the target's -max_len)."""
    out = []
    for folder in ("eds", os.path.join("tests", "vcan")):
        path = os.path.join(REPO, folder)
        for name in sorted(os.listdir(path)):
            if name.lower().endswith((".eds", ".dcf")):
                with open(os.path.join(path, name), "rb") as f:
                    out.append(f.read(2048))
    return out


def dcf_var(index, name, data_type, value, sub=None, default="0"):
    """One VAR section of a DCF (a sub-object section when `sub` is given)."""
    head = f"[{index:04X}]" if sub is None else f"[{index:04X}sub{sub:X}]"
    text = f"{head}\nParameterName={name}\nObjectType=0x7\nDataType=0x{data_type:04X}\nAccessType=rw\n"
    if default is not None:
        text += f"DefaultValue={default}\n"
    if value is not None:
        text += f"ParameterValue={value}\n"
    return text


def dcf_array(index, name, data_type, values):
    """A CiA 302 master array with only the sub-objects of the nodes in `values`."""
    text = f"[{index:04X}]\nParameterName={name}\nObjectType=0x8\nSubNumber={len(values) + 1}\n"
    text += f"[{index:04X}sub0]\nParameterName=Number of Entries\nObjectType=0x7\n" \
        "DataType=0x0005\nAccessType=ro\nDefaultValue=127\n"
    default = None if data_type == 0x000F else "0"
    for node, value in values.items():
        text += dcf_var(index, f"Node {node}", data_type, value, sub=node, default=default)
    return text


def concise(*entries):
    """A concise DCF: the entry count, then index, sub-index, size and data of each."""
    out = u32(len(entries))
    for index, sub, data in entries:
        out += u16(index) + bytes([sub]) + u32(len(data)) + data
    return out.hex().upper()


def master_dcfs():
    """Short master DCFs: the CiA 302 objects for a few slaves, sub-objects of those nodes only
    (a written master DCF lists all 127 and is far longer than the target's -max_len)."""
    head = "[FileInfo]\nFileName=master.dcf\nEDSVersion=4.0\n[DeviceComissioning]\nNodeID=1\n"
    full = head + dcf_var(0x1F80, "NMT Startup", 0x0007, "0x00000003") \
        + dcf_var(0x1F89, "Boot Time", 0x0007, "0x0000012C") \
        + dcf_array(0x1F81, "Slave Assignment", 0x0007,
                    {5: "0x0000000D", 6: "0x00000075", 9: "0x00000005"}) \
        + dcf_array(0x1F85, "Vendor Identification", 0x0007, {5: "0x00000039"}) \
        + dcf_array(0x1F22, "Concise DCF", 0x000F,
                    {9: concise((0x1017, 0, u16(100)), (0x2000, 1, u32(321)))}) \
        + dcf_array(0x1F53, "Expected Application SW Date", 0x0007, {6: "0x00003C28"}) \
        + dcf_array(0x1F58, "Program Data", 0x000F, {6: "0102FE"})
    small = head + dcf_var(0x1F80, "NMT Startup", 0x0007, "0x00000009") \
        + dcf_array(0x1F81, "Slave Assignment", 0x0007, {5: "0x00000005"}) \
        + dcf_array(0x1F22, "Concise DCF", 0x000F, {5: concise((0x1017, 0, u16(50)))})
    return [full.encode(), small.encode()]


# Targets whose input is an `arbitrary` structure: short byte strings of varied shape, so the
# first runs already decode into several operations.
ARBITRARY = [bytes(range(i, i + 48)) for i in (0, 7, 64, 200)] + [
    b"\x00\x01\x02\x03" * 12, b"\xff" * 32, bytes([3, 0, 16, 0, 1, 0x40, 0, 0x10, 0, 2] * 4),
]

# slcan adapter output and host commands (crates/slcan): the first byte is the chunk size the
# target splits the rest into; lines from the kernel driver, python-can, slcanpty, Lawicel and
# CANable firmware replies.
SLCAN = [
    bytes([7]) + b"t4563112233\rT12ABCDEF2AA55\rr1230\r",
    bytes([3]) + b"T1111222281122334455667788EA5F\rt10020011000A0\r",
    bytes([64]) + b"\rV1013\rN4242\rF00\r\x07z\rZ\r",
    bytes([16]) + b"d200900112233445566778899AABB\rB1FFFFFFFF" + b"E" * 128 + b"\r",
    bytes([5]) + b"sa057033\re3bcO\rb6fe3a1 git@github.com:normaldotcom/canable2-fw.git\r",
    bytes([1]) + b"C\rS6\rO\rL\rs001C\rY2\rZ1\rV\rN\rF\r",
    bytes([9]) + b"t12\xff30\rt1230\r\nt1231AA\x07\r",
]


TARGETS = {
    "sdo_decode_server": CLIENT_REQUESTS,
    "sdo_decode_client": SERVER_RESPONSES,
    "usdo_decode": USDO_FRAMES,
    "usdo_pair_sequence": ARBITRARY,
    "nmt_decoders": NMT_FRAMES,
    "lss_decoders": LSS_FRAMES,
    "canopen_candump": CANDUMP,
    # Bit-rate byte, then a log: heartbeats, boot-up, NMT, EMCY, SDO, SYNC, PDOs, error frames.
    "cli_analyze": [bytes([0x7F]) + s for s in CANDUMP] + [
        bytes([0x7F])
        + b"".join(
            b"(1700000000.%06d) can0 %s\n" % (t, f)
            for t, f in [
                (0, b"705#00"), (100, b"000#0105"), (10000, b"080#"), (20000, b"080#"),
                (30000, b"080#"), (40000, b"080#"), (50000, b"080#"), (60000, b"080#"),
                (100000, b"705#05"), (150000, b"185#0102"), (160000, b"185#0304"),
                (200000, b"705#05"), (210000, b"085#0050010000000000"),
                (220000, b"605#4018100100000000"), (221000, b"585#4318100179000000"),
                (230000, b"605#4000600100000000"), (231000, b"585#8000600100000206"),
                (300000, b"705#05"), (310000, b"20000040#0000000000000000"),
                (320000, b"7E5#0401000000000000"), (330000, b"000#8105"), (331000, b"000#0105"),
                (900000, b"705#00"),
            ]
        ),
    ],
    "canopen_udp_datagram": UDP,
    "gateway_line": GATEWAY,
    "burkert_values": BURKERT,
    "pdo_decode": PDO,
    "slcan_line": SLCAN,
    "od_value_text": OD_VALUES,
    "od_eds_parser": None,  # filled from the repository's EDS files
    "gemu_device_to_master": GEMU,
    "devicenet_decoders": DEVICENET,
    "devicenet_master_sequence": DEVICENET_SEQ,
    "devicenet_slave_sequence": DEVICENET_SEQ,
    "lss_slave_sequence": LSS_SEQ,
    # upload, crc, block size, length (u16 LE), then faults (kind, frame number) pairs.
    "sdo_block_link": [
        bytes([1, 1, 8, 100, 0, 0, 3]),
        bytes([0, 0, 8, 100, 0, 1, 8, 2, 3]),
        bytes([1, 0, 4, 0x10, 1, 0, 2, 1, 9, 2, 15]),
        bytes([0, 1, 127, 0xE8, 3]),
    ],
    "sdo_client_sequence": ARBITRARY + SERVER_RESPONSES,
    "sdo_server_sequence": ARBITRARY + CLIENT_REQUESTS,
    "nmt_monitor_sequence": ARBITRARY + NMT_FRAMES,
    "canopen_network_sequence": ARBITRARY,
    "manager_bus_toml": BUS_TOML,
    "manager_master_dcf": None,  # the manager's test DCFs
    # Head byte (low nibble: length, high nibble: TPDO number, bit 7: remote) then data.
    # Chunks of 8: statusword, 0x605A, target state, flags (bit 0 t16, 1 fault reset, 2-3 voltage
    # check, 4 enable from ready, 7 last controlword known), last controlword; first byte >= 0x80:
    # a write to the simulated drive and a step.
    "cia402_statusword_planner": [
        bytes([0x50, 0x02, 2, 0, 4, 0x87, 0x0F, 0]),  # SOD -> OE
        bytes([0x18, 0x02, 2, 0, 1, 0x83, 0x80, 0]),  # fault, bit 7 high before
        bytes([0x37, 0x02, 6, 0, 5, 0x03, 0, 0]) + bytes([0x17, 0x02, 6, 0, 4, 0x03, 0, 0]),
        bytes([0x21, 0x02, 2, 0, 4, 0x05, 0, 0]),  # RTSO without voltage
        bytes([0x0F, 0x00, 0xFF, 0xFF, 1, 0x00, 0, 0]),
        bytes([0x85, 12, 1, 0, 0, 0, 0x0F, 0]) + bytes([0x9C, 35, 0x10, 0x27, 0, 0, 0x1F, 0]),
    ],
    "pdo_typed": [bytes([0x18]) + bytes(range(8)), bytes([0x24, 1, 2, 3, 4]),
                  bytes([0x02, 0xFF, 0x7F]), bytes([0x80])],
}


def main():
    # The fuzz targets are the `[[bin]]`s of fuzz/Cargo.toml (fuzz_targets/ also holds shared modules).
    with open(os.path.join(ROOT, "Cargo.toml")) as f:
        targets = set(re.findall(r'^\[\[bin\]\]\s*\nname = "([^"]+)"', f.read(), re.M))
    TARGETS["od_eds_parser"] = eds_heads()
    TARGETS["manager_master_dcf"] = master_dcfs() + [
        repo_file("crates", "manager", "tests", "data", "valve.dcf")[:2048]
    ]
    for t in sorted(targets):
        seeds = TARGETS.get(t, ARBITRARY)
        folder = os.path.join(SEEDS, t)
        # Only the generated `seed-NN` files are replaced: inputs a fuzzer found and someone kept
        # (named for what they found) stay.
        os.makedirs(folder, exist_ok=True)
        for old in os.listdir(folder):
            if re.fullmatch(r"seed-\d+", old):
                os.remove(os.path.join(folder, old))
        for i, s in enumerate(seeds):
            with open(os.path.join(folder, f"seed-{i:02}"), "wb") as f:
                f.write(s)
        print(f"{t}: {len(seeds)} seeds{'' if t in TARGETS else ' (generic: not listed)'}")


if __name__ == "__main__":
    main()
