#!/usr/bin/env python3
"""asammdf's view of an MF4 file of signals, for tests/mf4_output.rs.

    dump.py FILE

One JSON object per channel (the master excepted): its group's name, its
name and unit, the absolute time of every record in ns (the header's start
time plus the master's seconds), and the values, null where the
invalidation bit is set. Run with the asammdf the test installs in a
scratch virtualenv; never a dependency of acq.
"""
import json
import sys
from datetime import timezone

from asammdf import MDF


def main():
    mdf = MDF(sys.argv[1])
    start = mdf.header.start_time.astimezone(timezone.utc)
    start_ns = int(start.timestamp()) * 1_000_000_000 + start.microsecond * 1000
    print(json.dumps({"comment": mdf.groups[0].data_group.comment if mdf.groups else ""}))
    for g, group in enumerate(mdf.groups):
        name = group.channel_group.acq_name
        for c, channel in enumerate(group.channels):
            if c == 0:
                continue
            signal = mdf.get(channel.name, g, c, ignore_invalidation_bits=True)
            invalid = signal.invalidation_bits
            values = [
                None if invalid is not None and bool(invalid[i]) else float(v)
                for i, v in enumerate(signal.samples)
            ]
            print(json.dumps({
                "group": name,
                "channel": channel.name,
                "unit": signal.unit,
                "time_ns": [start_ns + round(t * 1e9) for t in signal.timestamps],
                "values": values,
            }))


main()
