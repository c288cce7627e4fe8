"""asammdf's J1939 decoding of a bus log: `extract_bus_logging` with a DBC.

Usage: j1939.py LOG.mf4 FILE.dbc. Prints one JSON line per (signal, PGN,
source address): the values and their times in seconds from the log's
first frame. asammdf writes a group per logged id, each holding every
frame of its (PGN, source address); the first of each is kept.
"""

import json
import re
import sys

from asammdf import MDF

mdf = MDF(sys.argv[1])
decoded = mdf.extract_bus_logging({"CAN": [(sys.argv[2], 0)]})
first = min(
    float(sig.timestamps[0]) for sig in decoded.iter_channels() if len(sig.timestamps)
)
seen = set()
for index, group in enumerate(decoded.groups):
    found = re.search(r"PGN=0x([0-9A-Fa-f]+) SA=0x([0-9A-Fa-f]+)", group.channel_group.comment)
    if found is None:
        continue
    pgn, source = int(found.group(1), 16), int(found.group(2), 16)
    for channel in group.channels:
        if channel.name == "time" or (channel.name, pgn, source) in seen:
            continue
        seen.add((channel.name, pgn, source))
        sig = decoded.get(channel.name, group=index)
        print(
            json.dumps(
                {
                    "signal": channel.name,
                    "pgn": pgn,
                    "source_address": source,
                    "times_s": [float(t) - first for t in sig.timestamps],
                    "values": [float(v) for v in sig.samples],
                }
            )
        )
