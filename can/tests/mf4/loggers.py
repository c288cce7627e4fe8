"""MF4 bus logs shaped like CAN data loggers (CANedge and the like) write
them, to hold acq's MF4 reader against asammdf frame for frame.

    loggers.py OUT_DIR
    loggers.py OUT_DIR --frames N    (two of them with N frames each, for
                                      benches/mf4-vs-asammdf.sh; no .jsonl)

writes the files below into OUT_DIR and, beside each, FILE.expected.jsonl:
the frames a reader must get, one JSON object a line in time order, in the
shape of `frames.py read-asammdf FILE` ("timestamp_ns" from the HD start,
"timestamp_us" absolute and rounded half up, "dlc" = the data bytes' count).
Each file has its own frames (a seed per file name); two runs write the same
bytes (the DZ blocks given the same zlib). Run with the peers' virtualenv
(asammdf==8.8.28, numpy).

A. Written by asammdf (MDF.append, save): classic CAN, 500 frames. BusChannel
   (2), IDE (1) and Dir (0, Rx) are virtual constant members (cn_type 6, a
   linear CC); DataLength is DLC through a value-to-value table (CC 5); the
   master is an f64 of nanoseconds with a linear CC (1e-9); DataBytes[8] in
   the record, bytes past DataLength random. The members are siblings of a
   plain u8 `CAN_DataFrame` channel, not a composition.
     virtual_tab_ns.mf4                 records in one ##DT
     virtual_tab_ns_dz.mf4              ##DZ, deflate
     virtual_tab_ns_dz_transposed.mf4   ##DZ, transposed deflate
B. Laid out block by block. Record (21 bytes): f64 ns master, linear CC 1e-9
   | ID:29, IDE at bit 31 | DLC:4 and DataLength:4 (CC 5) on one nibble |
   DataBytes as a u64 VLSD offset. BusChannel is virtual (1); no Dir (Rx).
   Standard and extended ids, 0 to 8 data bytes, 500 frames.
     vlsd_sd.mf4          DataBytes in one ##SD
     vlsd_dz.mf4          in a ##DZ of SD (deflate)
     vlsd_sd_list.mf4     in a ##DL of two ##SD, cut inside a length prefix;
                          the first SD before the ##DT, the second after it
     vlsd_cg.mf4          in a VLSD CG of an unsorted DG, each VLSD record
                          before its frame record
     vlsd_cg_after.mf4    the same, each VLSD record after its frame record
     unfinalized_cut.mf4  vlsd_cg as a power cut leaves it: `UnFinMF `,
                          flags 0x25, CG counts and VLSD bytes 0, the ##DT's
                          length 24, the file ending 7 bytes short of the
                          last frame record (499 frames)
     unfinalized_dl.mf4   `UnFinMF `, flags 0x31, counts 0: vlsd_cg's records
                          cut across two ##DT that a ##DL (equal length)
                          lists in 2 of its 4 link slots (the others 0); the
                          rest in a ##DZ right after the DL, listed nowhere
C. Other record layouts, laid out by hand:
     vlsd_sd_fd.mf4       CAN FD and classic frames (200): Dir/EDL/BRS/ESI
                          bits above DLC, BusChannel u8 (1, 2), DataLength up
                          to 64 through CC 5, DataBytes in one ##SD
     master_us_u64.mf4    a u64 master of microseconds with a linear CC
                          (1e-6), BusChannel u8 (1, 2, 3), Dir bit,
                          DataBytes[8] in the record
     unfinalized_whole.mf4 `UnFinMF `, flags 0x05, count 0, the ##DT's
                          length 24 but no record cut (the file ends with the
                          last record); BusChannel u8 (1, 2), DataBytes[8]
                          in the record
D. A logger that writes fixed records and a channel group per bus and id
   kind (newer logger firmware: virtual constant members, fixed bytes): one
   unsorted DG (u8 record ids), four CAN_DataFrame CGs (buses 1, 2 x
   standard, extended), each record 1 + 21 bytes: f64 ns master (CC 1e-9)
   | ID:29 | DLC:4 = DataLength:4 (CC 5) | DataBytes[8]; BusChannel, IDE
   and Dir virtual constants (cn_type 6, a linear CC of slope 0).
     fixed_unsorted.mf4   500 frames, records in time order across the CGs
"""

import json
import struct
import sys
import zlib
from pathlib import Path

import numpy as np
from asammdf import MDF, Signal
from asammdf.blocks import v4_constants as v4c
from asammdf.blocks.source_utils import Source
from asammdf.blocks.v4_blocks import ChannelConversion, FileHistory

START_NS = 1_700_000_000_000_000_000  # HD start: 2023-11-14 22:13:20 UTC
FD_LEN = [0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64]
N = 500


# ---------------------------------------------------------------- frames

def frame_set(name, n=N, *, standard=True, buses=(1,), tx=False, fd=False, whole_us=False):
    """n frames with increasing whole-ns times (whole us if asked), seeded by
    the file name so that no two files hold the same frames."""
    rng = np.random.default_rng([74, zlib.crc32(name.encode())])
    frames, t = [], 0
    for _ in range(n):
        gap = int(rng.integers(100_000, 5_000_000))  # 0.1 to 5 ms
        t += gap - gap % 1000 if whole_us else gap
        extended = not standard or rng.random() < 0.7
        is_fd = fd and rng.random() < 0.7
        dlc = int(rng.integers(0, 16 if is_fd else 9))
        frames.append({
            "t_ns": t,
            "bus": int(rng.choice(buses)),
            "id": int(rng.integers(0, 1 << 29 if extended else 1 << 11)),
            "extended": bool(extended),
            "fd": is_fd,
            "brs": bool(is_fd and rng.random() < 0.5),
            "esi": bool(is_fd and rng.random() < 0.1),
            "dlc_code": dlc,
            "data": rng.integers(0, 256, FD_LEN[dlc], dtype="u1").tobytes(),
            "rx": not tx or bool(rng.random() < 0.8),
            # what a fixed DataBytes[8] holds past DataLength: not zeros
            "filler": rng.integers(0, 256, 8, dtype="u1").tobytes(),
        })
    return frames


def as_json(frame):
    """frames.py read-asammdf's shape."""
    t = frame["t_ns"]
    return {
        "timestamp_us": (START_NS + t + 500) // 1000,
        "timestamp_ns": t,
        "channel": frame["bus"],
        "id": frame["id"],
        "extended": frame["extended"],
        "remote": False,
        "error": False,
        "fd": frame["fd"],
        "brs": frame["brs"],
        "esi": frame["esi"],
        "dlc": len(frame["data"]),
        "data": frame["data"].hex(),
        "rx": frame["rx"],
    }


def fixed_bytes(frame):
    """DataBytes[8] as a record holds them: the data, then filler."""
    return frame["data"] + frame["filler"][len(frame["data"]):]


def id_field(frame):
    return frame["id"] | (1 << 31 if frame["extended"] else 0)


def vlsd_stream(frames):
    """The signal-data stream (u32 length, bytes per value) and each frame's
    offset into it."""
    stream, offsets = bytearray(), []
    for f in frames:
        offsets.append(len(stream))
        stream += struct.pack("<I", len(f["data"])) + f["data"]
    return bytes(stream), offsets


# ------------------------------------------------- A. written by asammdf

def asammdf_file(path, frames, compression):
    t = np.array([f["t_ns"] for f in frames], dtype="f8")  # raw master: ns
    ids = np.array([f["id"] for f in frames], dtype="<u4")
    dlc = np.array([f["dlc_code"] for f in frames], dtype="u1")
    data = np.frombuffer(b"".join(fixed_bytes(f) for f in frames), dtype="u1").reshape(-1, 8)
    zero, virtual = np.zeros(len(frames), "u1"), Signal.Flags.virtual

    def constant(name, value):  # asammdf's linear: a * index + b
        return Signal(zero, t, name=name, flags=virtual, virtual_conversion={"a": 0.0, "b": value})

    table = {f"raw_{i}": i for i in range(16)} | {f"phys_{i}": FD_LEN[i] for i in range(16)}
    mdf = MDF(version="4.11")
    mdf.append([
        Signal(zero, t, name="CAN_DataFrame"),  # the name asammdf's bus logging looks for
        constant("CAN_DataFrame.BusChannel", 2.0),
        Signal(ids, t, name="CAN_DataFrame.ID"),
        constant("CAN_DataFrame.IDE", 1.0),
        Signal(dlc, t, name="CAN_DataFrame.DLC"),
        Signal(dlc, t, name="CAN_DataFrame.DataLength", conversion=table),
        Signal(data, t, name="CAN_DataFrame.DataBytes"),
        constant("CAN_DataFrame.Dir", 0.0),
    ], acq_name="CAN2", common_timebase=True,
        acq_source=Source("CAN2", "CAN2", "", v4c.SOURCE_BUS, v4c.BUS_TYPE_CAN))
    group = mdf.groups[-1]
    group.channel_group.flags |= v4c.FLAG_CG_BUS_EVENT
    group.channels[0].conversion = ChannelConversion(conversion_type=v4c.CONVERSION_TYPE_LIN, a=1e-9, b=0.0)
    # asammdf stamps HD and its FH with the time of day: pin both
    mdf.header.abs_time, mdf.header.tz_offset = START_NS, 0
    mdf.header.daylight_save_time, mdf.header.time_flags = 0, v4c.FLAG_HD_TIME_OFFSET_VALID
    history = FileHistory()  # its constructor stamps the clock's time: overwrite
    history.abs_time, history.tz_offset, history.daylight_save_time = START_NS, 0, 0
    history.time_flags = v4c.FLAG_HD_TIME_OFFSET_VALID
    history.comment = "<FHcomment><TX>created</TX><tool_id>acq loggers.py</tool_id></FHcomment>"
    mdf.file_history = [history]
    mdf.save(path, overwrite=True, compression=compression, add_history_block=False)
    mdf.close()


# ---------------------------------------------------- B, C. block by block

class Blocks:
    """An MDF 4.11 file built block by block: 64 bytes of ##ID, then each
    block where it is written, 8-aligned."""

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

    def conversion(self, kind, values):
        return self.block(b"##CC", [0, 0, 0, 0],
                          struct.pack(f"<BBHHH2d{len(values)}d", kind, 0, 0, 0, len(values), 0, 0, *values))

    def channel(self, name, cn_type, data_type, byte, bit, bits, conversion=0, sync=0):
        fields = struct.pack("<4BIIIIBBH6d", cn_type, sync, data_type, bit, byte, bits, *[0] * 11)
        return self.block(b"##CN", [0, 0, self.text(name), 0, conversion, 0, 0, 0], fields)

    def data_list(self, blocks, *, equal=None, offsets=None):
        """##DL: equal length (flag 1) or one offset per block (flag 0)."""
        if equal is not None:
            fields = struct.pack("<B3xIQ", 1, len(blocks), equal)
        else:
            fields = struct.pack(f"<B3xI{len(blocks)}Q", 0, len(blocks), *offsets)
        return self.block(b"##DL", [0, *blocks], fields)

    def identify(self, unfinalized=0):
        """##ID last; `UnFinMF ` with the standard flags at @60 if any."""
        self.b[0:8] = b"UnFinMF " if unfinalized else b"MDF     "
        self.b[8:32] = b"4.11    acqtest \0\0\0\0" + struct.pack("<H", 411) + b"\0\0"
        struct.pack_into("<HH", self.b, 60, unfinalized, 0)


def linear(offset, factor):
    return (1, [offset, factor])  # MDF's P1 + P2 * raw


DLC_TABLE = (5, [v for i in range(16) for v in (i, FD_LEN[i])])  # value to value


class Layout:
    """A CAN_DataFrame record: its size, the master and members (name,
    cn_type, data_type, byte, bit, bits, conversion) and how a frame packs
    (given its VLSD offset, if any)."""

    def __init__(self, size, master, members, pack):
        self.size, self.master, self.members, self.pack = size, master, members, pack


# f64 ns | ID:29, IDE@31 | DLC:4 = DataLength:4 | DataBytes VLSD offset
VLSD = Layout(
    21, (4, linear(0.0, 1e-9)),
    [("BusChannel", 6, 0, 0, 0, 0, linear(1.0, 0.0)),  # virtual: 1 + 0 * index
     ("ID", 0, 0, 8, 0, 29, None), ("IDE", 0, 0, 11, 7, 1, None),
     ("DLC", 0, 0, 12, 0, 4, None), ("DataLength", 0, 0, 12, 0, 4, DLC_TABLE),
     ("DataBytes", 1, 10, 13, 0, 64, None)],
    lambda f, offset: struct.pack("<dIBQ", f["t_ns"], id_field(f), f["dlc_code"], offset))

# f64 ns | ID:29, IDE@31 | DLC:4 = DataLength:4, Dir, EDL, BRS, ESI | BusChannel | VLSD offset
VLSD_FD = Layout(
    22, (4, linear(0.0, 1e-9)),
    [("BusChannel", 0, 0, 13, 0, 8, None),
     ("ID", 0, 0, 8, 0, 29, None), ("IDE", 0, 0, 11, 7, 1, None),
     ("DLC", 0, 0, 12, 0, 4, None), ("DataLength", 0, 0, 12, 0, 4, DLC_TABLE),
     ("Dir", 0, 0, 12, 4, 1, None), ("EDL", 0, 0, 12, 5, 1, None),
     ("BRS", 0, 0, 12, 6, 1, None), ("ESI", 0, 0, 12, 7, 1, None),
     ("DataBytes", 1, 10, 14, 0, 64, None)],
    lambda f, offset: struct.pack(
        "<dIBBQ", f["t_ns"], id_field(f),
        f["dlc_code"] | (not f["rx"]) << 4 | f["fd"] << 5 | f["brs"] << 6 | f["esi"] << 7,
        f["bus"], offset))

# f64 ns | ID:29, IDE@31 | DLC:4 = DataLength:4 | DataBytes[8] | BusChannel
FIXED = Layout(
    22, (4, linear(0.0, 1e-9)),
    [("BusChannel", 0, 0, 21, 0, 8, None),
     ("ID", 0, 0, 8, 0, 29, None), ("IDE", 0, 0, 11, 7, 1, None),
     ("DLC", 0, 0, 12, 0, 4, None), ("DataLength", 0, 0, 12, 0, 4, DLC_TABLE),
     ("DataBytes", 0, 10, 13, 0, 64, None)],
    lambda f, offset: struct.pack("<dIB8sB", f["t_ns"], id_field(f), f["dlc_code"],
                                  fixed_bytes(f), f["bus"]))

# u64 us | BusChannel | ID:29, IDE@31 | DLC:4 = DataLength:4 (no CC), Dir | DataBytes[8]
MICROSECONDS = Layout(
    22, (0, linear(0.0, 1e-6)),
    [("BusChannel", 0, 0, 8, 0, 8, None),
     ("ID", 0, 0, 9, 0, 29, None), ("IDE", 0, 0, 12, 7, 1, None),
     ("DLC", 0, 0, 13, 0, 4, None), ("DataLength", 0, 0, 13, 0, 4, None),
     ("Dir", 0, 0, 13, 4, 1, None),
     ("DataBytes", 0, 10, 14, 0, 64, None)],
    lambda f, offset: struct.pack("<QBIB8s", f["t_ns"] // 1000, f["bus"], id_field(f),
                                  f["dlc_code"] | (not f["rx"]) << 4, fixed_bytes(f)))


def header(w, record_id):
    """HD, FH and the DG (u8 record ids if record_id). Returns the dg."""
    hd = w.block(b"##HD", [0] * 6, struct.pack("<QhhBBBxdd", START_NS, 60, 0, 2, 0, 0, 0, 0))
    fh = w.block(b"##FH", [0, w.text("<FHcomment><TX>created</TX><tool_id>acq loggers.py</tool_id></FHcomment>")],
                 struct.pack("<QhhB3x", START_NS, 60, 0, 2))
    w.link(hd, 1, fh)
    dg = w.block(b"##DG", [0] * 4, struct.pack("<B7x", 1 if record_id else 0))
    w.link(hd, 0, dg)
    return dg


def metadata(w, layout, *, record_id=0, cycles):
    """HD, FH, DG and the CAN_DataFrame CG (bus event) with its channels, as
    loggers write them: before the data. Returns (dg, cg, DataBytes cn)."""
    dg = header(w, record_id)
    cg, data_bytes = channel_group(w, layout, record_id=record_id, cycles=cycles)
    w.link(dg, 1, cg)
    return dg, cg, data_bytes


def channel_group(w, layout, *, record_id, cycles, bus_name="CAN1"):
    """A CAN_DataFrame CG (bus event) with its channels. Returns (cg,
    DataBytes cn)."""
    source = w.block(b"##SI", [w.text(bus_name), w.text(bus_name), 0], struct.pack("<BBB5x", 2, 2, 0))
    cg = w.block(b"##CG", [0, 0, w.text(bus_name), source, 0, 0],
                 struct.pack("<QQHH4xII", record_id, cycles, v4c.FLAG_CG_BUS_EVENT, ord("."), layout.size, 0))
    members = [w.channel("CAN_DataFrame." + name, cn_type, data_type, byte, bit, bits,
                         conversion=w.conversion(*cc) if cc else 0)
               for name, cn_type, data_type, byte, bit, bits, cc in layout.members]
    for a, b in zip(members, members[1:]):
        w.link(a, 0, b)
    frame = w.channel("CAN_DataFrame", 0, 10, 8, 0, 8 * (layout.size - 8))
    w.link(frame, 1, members[0])
    data_type, cc = layout.master
    master = w.channel("Timestamp", 2, data_type, 0, 0, 64, conversion=w.conversion(*cc), sync=1)
    w.link(master, 0, frame)
    w.link(cg, 1, master)
    names = [m[0] for m in layout.members]
    return cg, members[names.index("DataBytes")]


def sorted_file(path, frames, layout, storage="dt", unfinalized=0):
    """One sorted DG (no record ids); DataBytes VLSD in storage "sd", "dz"
    or "sd_list", or fixed in the record ("dt")."""
    w = Blocks()
    dg, cg, data_bytes = metadata(w, layout, cycles=0 if unfinalized else len(frames))
    stream, offsets = vlsd_stream(frames)
    records = b"".join(layout.pack(f, o) for f, o in zip(frames, offsets))
    if storage == "sd":
        w.link(data_bytes, 5, w.block(b"##SD", [], stream))
    elif storage == "dz":
        z = zlib.compress(stream)
        w.link(data_bytes, 5, w.block(b"##DZ", [], b"SD" + struct.pack("<BxIQQ", 0, 0, len(stream), len(z)) + z))
    elif storage == "sd_list":
        # cut 2 bytes into the middle frame's u32 length: neither block holds
        # that value whole, not even its length
        cut = offsets[len(frames) // 2] + 2
        first = w.block(b"##SD", [], stream[:cut])
    dt = w.block(b"##DT", [], records)
    w.link(dg, 2, dt)
    if storage == "sd_list":
        second = w.block(b"##SD", [], stream[cut:])
        w.link(data_bytes, 5, w.data_list([first, second], offsets=[0, cut]))
    if unfinalized:
        # never updated: the DT's length (header only); the file ends with
        # the last record, no padding
        struct.pack_into("<Q", w.b, dt + 8, 24)
        del w.b[dt + 24 + len(records):]
    w.identify(unfinalized)
    Path(path).write_bytes(w.b)
    return frames


def vlsd_cg_file(path, frames, *, vlsd_after=False, unfinalized=0, cut=0, dl_slots=0):
    """CANedge's shape: one unsorted DG (u8 record ids), the CAN CG (id 1,
    bus event), then in the CG chain its VLSD CG (id 2, flags VLSD) which
    DataBytes' data link names. Records: 1 + 21 fixed bytes, 2 + u32 length
    + the bytes; their order as vlsd_after says."""
    w = Blocks()
    dg, cg, data_bytes = metadata(w, VLSD, record_id=1, cycles=0 if unfinalized else len(frames))
    stream, offsets = vlsd_stream(frames)
    vlsd = w.block(b"##CG", [0] * 6, struct.pack(
        "<QQHH4xQ", 2, 0 if unfinalized else len(frames), v4c.FLAG_CG_VLSD, 0, 0 if unfinalized else len(stream)))
    w.link(cg, 0, vlsd)
    w.link(data_bytes, 5, vlsd)
    records, starts = bytearray(), set()
    for f, o in zip(frames, offsets):
        fixed = b"\x01" + VLSD.pack(f, o)
        value = b"\x02" + struct.pack("<I", len(f["data"])) + f["data"]
        for record in (fixed, value) if vlsd_after else (value, fixed):
            starts.add(len(records))
            records += record
    if dl_slots:
        # two DTs of `equal` bytes, records cut across them; after them the
        # DL, listing them in 2 of its dl_slots; right after the DL the rest
        # in a ##DZ that no DL lists. (A ##DT there asammdf 8.8.28 cannot
        # read: _finalize takes its length from the DT's bytes 30..38.)
        equal = len(records) * 2 // 5
        while equal in starts or 2 * equal in starts:  # both cuts inside a record
            equal += 1
        dts = [w.block(b"##DT", [], bytes(records[:equal])),
               w.block(b"##DT", [], bytes(records[equal:2 * equal]))]
        w.link(dg, 2, w.data_list(dts + [0] * (dl_slots - len(dts)), equal=equal))
        rest = bytes(records[2 * equal:])
        z = zlib.compress(rest)
        w.block(b"##DZ", [], b"DT" + struct.pack("<BxIQQ", 0, 0, len(rest), len(z)) + z)
    else:
        dt = w.block(b"##DT", [], bytes(records))
        w.link(dg, 2, dt)
    if unfinalized & v4c.FLAG_UNFIN_UPDATE_LAST_DT_LENGTH:
        # the DT's length never written (header only); the file ends with
        # the last record, cut short by `cut` bytes
        struct.pack_into("<Q", w.b, dt + 8, 24)
        del w.b[dt + 24 + len(records) - cut:]
    w.identify(unfinalized)
    Path(path).write_bytes(w.b)
    # a cut record is lost: the frames a reader gets are the whole ones
    return frames[:-1] if cut else frames


def virtual_fixed(bus, extended):
    """D's record: f64 ns | ID:29 | DLC:4 = DataLength:4 | DataBytes[8];
    bus, IDE and Dir (Rx) virtual constants of the CG."""
    constant = lambda value: linear(float(value), 0.0)
    return Layout(
        21, (4, linear(0.0, 1e-9)),
        [("BusChannel", 6, 0, 0, 0, 0, constant(bus)),
         ("ID", 0, 0, 8, 0, 29, None), ("IDE", 6, 0, 0, 0, 0, constant(extended)),
         ("DLC", 0, 0, 12, 0, 4, None), ("DataLength", 0, 0, 12, 0, 4, DLC_TABLE),
         ("DataBytes", 0, 10, 13, 0, 64, None), ("Dir", 6, 0, 0, 0, 0, constant(0))],
        lambda f, offset: struct.pack("<dIB8s", f["t_ns"], f["id"], f["dlc_code"], fixed_bytes(f)))


def fixed_unsorted_file(path, frames):
    """D: one unsorted DG, a CG per (bus, standard or extended), fixed
    records in time order."""
    w = Blocks()
    dg = header(w, record_id=1)
    kinds = [(bus, extended) for bus in (1, 2) for extended in (0, 1)]
    record_id = {kind: index + 1 for index, kind in enumerate(kinds)}
    layouts = {kind: virtual_fixed(*kind) for kind in kinds}
    kind_of = lambda f: (f["bus"], int(f["extended"]))
    previous = None
    for kind in kinds:
        cycles = sum(1 for f in frames if kind_of(f) == kind)
        cg, _ = channel_group(w, layouts[kind], record_id=record_id[kind], cycles=cycles,
                              bus_name=f"CAN{kind[0]}")
        if previous is None:
            w.link(dg, 1, cg)
        else:
            w.link(previous, 0, cg)
        previous = cg
    records = b"".join(bytes([record_id[kind_of(f)]]) + layouts[kind_of(f)].pack(f, 0) for f in frames)
    w.link(dg, 2, w.block(b"##DT", [], records))
    w.identify()
    Path(path).write_bytes(w.b)
    return frames


# ----------------------------------------------------------------- files

def bench(out, frames):
    """Three large files for benches/mf4-vs-asammdf.sh: two shaped as
    loggers write them (VLSD channel group, unsorted; fixed records, a CG
    per bus and id kind, unsorted) and an asammdf-written one."""
    name = "vlsd_cg.mf4"
    vlsd_cg_file(out / name, frame_set(name, frames))
    name = "virtual_tab_ns.mf4"
    asammdf_file(out / name, frame_set(name, frames, standard=False, buses=(2,)), 0)
    name = "fixed_unsorted.mf4"
    fixed_unsorted_file(out / name, frame_set(name, frames, buses=(1, 2)))


def main():
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    if len(sys.argv) == 4 and sys.argv[2] == "--frames":
        bench(out, int(sys.argv[3]))
        return
    unfinalized_cut = (v4c.FLAG_UNFIN_UPDATE_CG_COUNTER | v4c.FLAG_UNFIN_UPDATE_LAST_DT_LENGTH
                       | v4c.FLAG_UNFIN_UPDATE_VLSD_BYTES)                                   # 0x25
    unfinalized_dl = (v4c.FLAG_UNFIN_UPDATE_CG_COUNTER | v4c.FLAG_UNFIN_UPDATE_LAST_DL
                      | v4c.FLAG_UNFIN_UPDATE_VLSD_BYTES)                                    # 0x31
    unfinalized_whole = v4c.FLAG_UNFIN_UPDATE_CG_COUNTER | v4c.FLAG_UNFIN_UPDATE_LAST_DT_LENGTH  # 0x05
    written = {}  # name: the frames a reader must get
    for name, compression in [("virtual_tab_ns.mf4", 0), ("virtual_tab_ns_dz.mf4", 1),
                              ("virtual_tab_ns_dz_transposed.mf4", 2)]:
        written[name] = frame_set(name, standard=False, buses=(2,))
        asammdf_file(out / name, written[name], compression)
    for name, storage in [("vlsd_sd.mf4", "sd"), ("vlsd_dz.mf4", "dz"), ("vlsd_sd_list.mf4", "sd_list")]:
        written[name] = sorted_file(out / name, frame_set(name), VLSD, storage)
    for name, options in [("vlsd_cg.mf4", {}), ("vlsd_cg_after.mf4", {"vlsd_after": True}),
                          ("unfinalized_cut.mf4", {"unfinalized": unfinalized_cut, "cut": 7}),
                          ("unfinalized_dl.mf4", {"unfinalized": unfinalized_dl, "dl_slots": 4})]:
        written[name] = vlsd_cg_file(out / name, frame_set(name), **options)
    name = "vlsd_sd_fd.mf4"
    written[name] = sorted_file(out / name, frame_set(name, 200, buses=(1, 2), tx=True, fd=True),
                                VLSD_FD, "sd")
    name = "master_us_u64.mf4"
    written[name] = sorted_file(out / name, frame_set(name, buses=(1, 2, 3), tx=True, whole_us=True),
                                MICROSECONDS)
    name = "unfinalized_whole.mf4"
    written[name] = sorted_file(out / name, frame_set(name, buses=(1, 2)), FIXED,
                                unfinalized=unfinalized_whole)
    name = "fixed_unsorted.mf4"
    written[name] = fixed_unsorted_file(out / name, frame_set(name, buses=(1, 2)))
    for name, frames in written.items():
        with open(out / (name + ".expected.jsonl"), "w") as expected:
            expected.writelines(json.dumps(as_json(f)) + "\n" for f in frames)


main()
