"""python-can's side of can/tests/it/mf4.rs (MF4 through asammdf).

    frames.py write FRAMES.jsonl OUT.mf4 LEVEL   python-can writes the frames
                                                 (LEVEL: asammdf compression
                                                 0 none, 1 deflate, 2
                                                 transposed deflate)
    frames.py read FILE.mf4                      one JSON object per frame
                                                 python-can reads

A frame is {"timestamp_us", "channel", "id", "extended", "remote", "error",
"fd", "brs", "esi", "dlc", "data" (hex), "rx"}. Run with the python-can
the test installs in a scratch virtualenv; never a dependency of acq.
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
    else:
        sys.exit("usage: frames.py write FRAMES.jsonl OUT.mf4 LEVEL | read FILE.mf4")


main()
