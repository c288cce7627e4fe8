"""python-can's side of can/tests/it/mf4.rs (MF4 through asammdf).

    frames.py write FRAMES.jsonl OUT.mf4 LEVEL   python-can writes the frames
                                                 (LEVEL: asammdf compression
                                                 0 none, 1 deflate, 2
                                                 transposed deflate)
    frames.py read FILE.mf4                      one JSON object per frame
                                                 python-can reads
    frames.py read-asammdf FILE.mf4              one JSON object per CAN
                                                 data frame asammdf reads
                                                 (asammdf itself, no
                                                 python-can), in time order

A frame is {"timestamp_us", "channel", "id", "extended", "remote", "error",
"fd", "brs", "esi", "dlc", "data" (hex), "rx"}. read-asammdf adds
"timestamp_ns" after "timestamp_us": the master's seconds as whole
nanoseconds (round(t * 1e9)) from the HD start; "timestamp_us" is then
absolute, (HD start ns + timestamp_ns) / 1000 rounded half up. It reads the
bus-event groups (FLAG_CG_BUS_EVENT) whose first channel after the master is
`CAN_DataFrame`; members it lacks take defaults (BusChannel 0, IDE from bit
31 of ID, Dir rx, EDL/BRS/ESI 0) and "dlc" is DataLength, the data bytes'
count. Run with the python-can the test installs in a scratch virtualenv;
never a dependency of acq.
"""
import json
import sys

import can


def message(frame):
    common = dict(
        timestamp=frame["timestamp_us"] / 1e6,
        channel=frame["channel"],
        is_rx=frame["rx"],
    )
    if frame["error"]:
        return can.Message(is_error_frame=True, **common)
    return can.Message(
        arbitration_id=frame["id"],
        is_extended_id=frame["extended"],
        is_remote_frame=frame["remote"],
        is_fd=frame["fd"],
        bitrate_switch=frame["brs"],
        error_state_indicator=frame["esi"],
        dlc=frame["dlc"],
        data=bytes.fromhex(frame["data"]),
        **common,
    )


def asammdf_frames(path):
    """The CAN data frames of every bus-logging group, as asammdf reads
    them, merged by time (a stable sort: ties keep group, then record
    order)."""
    from asammdf import MDF
    from asammdf.blocks import v4_constants as v4c

    mdf = MDF(path)
    start_ns = int(mdf.header.abs_time)
    frames = []
    for g, group in enumerate(mdf.groups):
        if not group.channel_group.flags & v4c.FLAG_CG_BUS_EVENT:
            continue
        channels = [c for c in group.channels if c.channel_type not in v4c.MASTER_TYPES]
        if not channels or channels[0].name != "CAN_DataFrame":
            continue
        members = {c.name[len("CAN_DataFrame."):]: i for i, c in enumerate(group.channels)
                   if c.name.startswith("CAN_DataFrame.")}
        ids = mdf.get(group=g, index=members["ID"], raw=False)
        count = len(ids)

        def ints(name, default):
            """A member's values as ints, or `default` for each record."""
            if name not in members:
                return [default] * count
            signal = mdf.get(group=g, index=members[name], raw=False)
            if signal.samples.dtype.kind not in "biuf":
                # a value-to-text conversion (Dir as "Rx"/"Tx"): the raw
                # value counts, as in asammdf's bus-logging extraction
                signal = mdf.get(group=g, index=members[name], raw=True)
            return [int(round(float(v))) for v in signal.samples]

        times = [round(float(t) * 1e9) for t in ids.timestamps]
        raw_ids = [int(v) for v in ids.samples]
        ide = ints("IDE", None)
        lengths = ints("DataLength" if "DataLength" in members else "DLC", 0)
        data = (data_rows(mdf.get(group=g, index=members["DataBytes"], raw=False))
                if "DataBytes" in members else [b""] * count)
        channel = ints("BusChannel", 0)
        direction = ints("Dir", 0)
        edl, brs, esi = ints("EDL", 0), ints("BRS", 0), ints("ESI", 0)
        for k in range(count):
            extended = bool(raw_ids[k] >> 31 & 1) if ide[k] is None else bool(ide[k])
            frames.append({
                "timestamp_us": (start_ns + times[k] + 500) // 1000,
                "timestamp_ns": times[k],
                "channel": channel[k],
                "id": raw_ids[k] & 0x1FFFFFFF,
                "extended": extended,
                "remote": False,
                "error": False,
                "fd": bool(edl[k]),
                "brs": bool(brs[k]),
                "esi": bool(esi[k]),
                "dlc": lengths[k],
                "data": data[k][:lengths[k]].hex(),
                "rx": direction[k] == 0,
            })
    frames.sort(key=lambda frame: frame["timestamp_ns"])
    return frames


def data_rows(signal):
    """DataBytes as one bytes value per record: asammdf gives a 2-D uint8
    array (fixed in the record, or VLSD padded with zeros to the longest)
    or, for some VLSD channels, bytes/object values."""
    samples = signal.samples
    if not len(samples):
        return []
    if samples.dtype.kind == "S":
        # numpy drops trailing NULs of an S item: take its whole buffer
        return [bytes(row) for row in samples.view("u1").reshape(len(samples), -1)]
    if samples.dtype.kind == "O":
        return [bytes(value) for value in samples]
    return [row.tobytes() for row in samples.reshape(len(samples), -1)]


def main():
    if sys.argv[1] == "write":
        with open(sys.argv[2]) as frames:
            messages = [message(json.loads(line)) for line in frames if line.strip()]
        writer = can.MF4Writer(sys.argv[3], compression_level=int(sys.argv[4]))
        for m in messages:
            writer.on_message_received(m)
        writer.stop()
    elif sys.argv[1] == "read":
        for m in can.MF4Reader(sys.argv[2]):
            error = m.is_error_frame
            print(json.dumps({
                "timestamp_us": round(m.timestamp * 1e6),
                "channel": int(m.channel),
                "id": 0 if error else m.arbitration_id,
                "extended": False if error else m.is_extended_id,
                "remote": m.is_remote_frame,
                "error": error,
                "fd": m.is_fd,
                "brs": m.bitrate_switch,
                "esi": m.error_state_indicator,
                "dlc": 0 if error else m.dlc,
                "data": "" if error else m.data.hex(),
                "rx": m.is_rx,
            }))
    elif sys.argv[1] == "read-asammdf":
        for frame in asammdf_frames(sys.argv[2]):
            print(json.dumps(frame))
    else:
        sys.exit("usage: frames.py write FRAMES.jsonl OUT.mf4 LEVEL | read FILE.mf4"
                 " | read-asammdf FILE.mf4")


main()
