"""python-can's view of a CAN log, for tests/python_can.rs.

    frames.py read FILE        one JSON object per frame python-can reads
    frames.py asc CANDUMP OUT  python-can reads a candump log, writes it as ASC
    frames.py blf CANDUMP OUT  the same, as BLF
    frames.py log CANDUMP OUT  the same, as candump -L (python-can's writer)
    frames.py mf4 CANDUMP OUT  the same, as ASAM MF4 (python-can's writer,
                               through asammdf)

Run with the python-can the test installs in a scratch virtualenv; never a
dependency of acq.
"""
import json
import sys

import can


def reader(path):
    if path.endswith(".asc"):
        return can.ASCReader(path, relative_timestamp=False)
    if path.endswith(".blf"):
        return can.BLFReader(path)
    return can.CanutilsLogReader(path)


def channel_number(channel):
    # ASC channels are 0-based ints in python-can, candump ones "canN".
    if isinstance(channel, str) and channel.startswith("can"):
        return int(channel[3:])
    return int(channel)


def main():
    if sys.argv[1] == "read":
        for message in reader(sys.argv[2]):
            print(json.dumps({
                "timestamp_us": round(message.timestamp * 1e6),
                # python-can's candump reader gives error frames no channel.
                "channel": None if message.is_error_frame else channel_number(message.channel),
                "id": message.arbitration_id,
                "extended": message.is_extended_id,
                "remote": message.is_remote_frame,
                "error": message.is_error_frame,
                "fd": message.is_fd,
                "brs": message.bitrate_switch,
                "esi": message.error_state_indicator,
                "dlc": message.dlc,
                "data": message.data.hex() if not message.is_error_frame else "",
            }))
    elif sys.argv[1] in ("asc", "blf", "log", "mf4"):
        writer_class = {
            "asc": can.ASCWriter,
            "blf": can.BLFWriter,
            "log": can.CanutilsLogWriter,
            "mf4": can.MF4Writer,
        }[sys.argv[1]]
        with writer_class(sys.argv[3]) as writer:
            for message in can.CanutilsLogReader(sys.argv[2]):
                writer.on_message_received(message)
    else:
        sys.exit("usage: frames.py read FILE | asc|blf|log|mf4 CANDUMP OUT")


main()
