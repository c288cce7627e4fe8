"""An MF4 bus log whose time master is a float64 of nanoseconds with a
linear conversion to seconds (b = 1e-9), as a CAN data logger writes it;
DataBytes fixed inside the record. Usage: float_master.py OUT.mf4.
Prints the frames written (on bus 1: can1), one JSON line each: time_ns,
id, extended, data."""

import json
import struct
import sys

START_NS = 1_700_000_000_000_000_000


class Blocks:
    def __init__(self):
        self.b = bytearray(64)

    def block(self, kind, links, data=b""):
        at = len(self.b)
        length = 24 + 8 * len(links) + len(data)
        self.b += kind + b"\0" * 4 + struct.pack("<QQ", length, len(links))
        self.b += struct.pack(f"<{len(links)}Q", *links) + data
        self.b += b"\0" * (-len(self.b) % 8)
        return at

    def link(self, at, index, to):
        struct.pack_into("<Q", self.b, at + 24 + 8 * index, to)

    def text(self, text):
        return self.block(b"##TX", [], text.encode() + b"\0")

    def linear(self, a, b):
        return self.block(b"##CC", [0, 0, 0, 0], struct.pack("<BBHHH2d2d", 1, 0, 0, 0, 2, 0, 0, a, b))

    def channel(self, name, cn_type, data_type, byte, bit, bits, conversion=0, sync=0):
        fields = struct.pack("<4BIIIIBBH6d", cn_type, sync, data_type, bit, byte, bits, *[0] * 11)
        return self.block(b"##CN", [0, 0, self.text(name), 0, conversion, 0, 0, 0], fields)


frames = []
time_ns = 0.0
for k in range(300):
    time_ns += 1_000_000 + 37_123 * (k % 7)  # 1 ms and a varying part, whole ns
    extended = k % 3 != 0
    can_id = (0x18FEF100 + k) & 0x1FFFFFFF if extended else (0x100 + k) & 0x7FF
    dlc = k % 9
    data = bytes((k * 7 + i) & 0xFF for i in range(dlc))
    frames.append((time_ns, can_id, extended, dlc, data))

w = Blocks()
w.b[0:8] = b"MDF     "
hd = w.block(b"##HD", [0] * 6, struct.pack("<QhhBBBxdd", START_NS, 0, 0, 2, 0, 0, 0, 0))
dg = w.block(b"##DG", [0] * 4, struct.pack("<B7x", 0))
w.link(hd, 0, dg)
size = 8 + 4 + 1 + 8 + 1  # time f64 ns | ID:29 IDE:1@31 | DLC:4 | DataBytes[8] | BusChannel
source = w.block(b"##SI", [w.text("CAN1"), w.text("CAN1"), 0], struct.pack("<BBB5x", 2, 2, 0))
cg = w.block(b"##CG", [0, 0, w.text("CAN1"), source, 0, 0],
             struct.pack("<QQHH4xII", 0, len(frames), 2, ord("."), size, 0))
w.link(dg, 1, cg)
members = [
    w.channel("CAN_DataFrame.BusChannel", 0, 0, 21, 0, 8),
    w.channel("CAN_DataFrame.ID", 0, 0, 8, 0, 29),
    w.channel("CAN_DataFrame.IDE", 0, 0, 11, 7, 1),
    w.channel("CAN_DataFrame.DLC", 0, 0, 12, 0, 4),
    w.channel("CAN_DataFrame.DataLength", 0, 0, 12, 0, 4),
    w.channel("CAN_DataFrame.DataBytes", 0, 10, 13, 0, 64),
]
for a, b in zip(members, members[1:]):
    w.link(a, 0, b)
frame = w.channel("CAN_DataFrame", 0, 10, 8, 0, 8 * (size - 8))
w.link(frame, 1, members[0])
master = w.channel("Timestamp", 2, 4, 0, 0, 64, conversion=w.linear(0.0, 1e-9), sync=1)
w.link(master, 0, frame)
w.link(cg, 1, master)
records = bytearray()
for time_ns, can_id, extended, dlc, data in frames:
    records += struct.pack("<dIB", time_ns, can_id | (1 << 31 if extended else 0), dlc)
    records += data.ljust(8, b"\0") + bytes([1])
dt = w.block(b"##DT", [], bytes(records))
w.link(dg, 2, dt)
w.b[8:32] = b"4.11    acqtest " + b"\0" * 4 + struct.pack("<H", 411) + b"\0\0"
with open(sys.argv[1], "wb") as out:
    out.write(w.b)
for time_ns, can_id, extended, dlc, data in frames:
    print(json.dumps({"time_ns": START_NS + int(time_ns), "id": can_id, "extended": extended,
                      "data": data.hex()}))
