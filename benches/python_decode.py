"""Decoding from Python against the CLI and against cantools, same log, same
machine, same run (python/ issue 54's speed targets).

    target/tmp/acq-python-dev/bin/python benches/python_decode.py [REPEATS]

The log: the frames of the shipped excavator_case1 session's raw.log that
the DBC describes (the DAQ's strain and force frames; its CANopen
transducers are not in the DBC), written REPEATS times (default 200) one
after another, each copy shifted by the session's length, into a temporary
candump log. Decoded through the
somat_excavator DBC:
- acq.decode(log, dbc=...) in this interpreter (a pyarrow.Table);
- `acq decode LOG --dbc DBC -o FILE.parquet` (the CLI, release build);
- cantools in this interpreter, over the first 100,000 lines (its rate
  then scales): the lines parsed and every frame decoded with
  Database.decode_message, and decode_message alone on frames parsed
  beforehand;
- python-can's LogReader over the same lines with cantools' decode (the
  pair a notebook uses; python-can is cantools' own dependency).
Each time is the best of 3. Exits 1 when acq.decode is less than 50 times
faster than python-can with cantools (the goal).
"""

import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import acq
import can
import cantools

REPO = Path(__file__).resolve().parent.parent
SESSION_LOG = REPO / "fixtures/sessions/excavator_case1/raw.log"
DBC = REPO / "fixtures/dbc/somat_excavator.dbc"
ACQ = REPO / "target/release/acq"
GOAL = 50
LINE = re.compile(r"\((\d+)\.(\d+)\) (\S+) ([0-9A-Fa-f]+)#([0-9A-Fa-f]*)")


def best_of(runs, work):
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        work()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 200
    db = cantools.database.load_file(str(DBC))
    known = {m.frame_id for m in db.messages}
    lines = SESSION_LOG.read_text().splitlines()
    parsed = [m for m in map(LINE.match, lines) if m and int(m.group(4), 16) in known]
    first = int(parsed[0].group(1))
    span = int(parsed[-1].group(1)) - first + 1
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "long.log"
        with open(log, "w") as out:
            for k in range(repeats):
                for m in parsed:
                    out.write(f"({int(m.group(1)) + k * span}.{m.group(2)}) {m.group(3)} {m.group(4)}#{m.group(5)}\n")
        frames = len(parsed) * repeats
        size_mb = log.stat().st_size / 1e6

        table = acq.decode(log, dbc=DBC)
        python_s = best_of(3, lambda: acq.decode(log, dbc=DBC))
        parquet = Path(tmp) / "cli.parquet"
        cli = [str(ACQ), "decode", str(log), "--dbc", str(DBC), "-o", str(parquet)]
        cli_s = best_of(3, lambda: subprocess.run(cli, check=True, capture_output=True))

        # cantools does the same job in Python: the log's lines read and
        # parsed (as a Python user writes it, a regular expression per
        # line), each frame decoded; over the first 100,000 lines.
        with open(log) as f:
            head = [next(f) for _ in range(min(frames, 100_000))]

        def cantools_decode() -> int:
            rows = 0
            for line in head:
                m = LINE.match(line)
                rows += len(db.decode_message(int(m.group(4), 16), bytes.fromhex(m.group(5))))
            return rows

        def cantools_only() -> int:
            rows = 0
            for frame_id, data in parsed_head:
                rows += len(db.decode_message(frame_id, data))
            return rows

        # The reader a python-can user opens the log with (cantools'
        # own dependency), then cantools' decode: the usual notebook pair.
        head_log = Path(tmp) / "head.log"
        head_log.write_text("".join(head))

        def python_can_and_cantools() -> int:
            rows = 0
            for message in can.LogReader(str(head_log)):
                rows += len(db.decode_message(message.arbitration_id, message.data))
            return rows

        parsed_head = [(int(m.group(4), 16), bytes.fromhex(m.group(5))) for m in map(LINE.match, head)]
        decode_only_s = best_of(3, cantools_only) * frames / len(head)
        python_can_s = best_of(3, python_can_and_cantools) * frames / len(head)
        cantools_s = best_of(3, cantools_decode) * frames / len(head)
        print(
            f"{frames} frames ({size_mb:.0f} MB candump), {table.num_rows} values: "
            f"acq.decode {python_s:.3f} s ({frames / python_s / 1e6:.2f} M frames/s); "
            f"acq decode -o .parquet (CLI) {cli_s:.3f} s; Python / CLI = {python_s / cli_s:.2f}; "
            f"cantools reading and decoding the log (scaled from 100,000 lines) {cantools_s:.1f} s, cantools / acq.decode = {cantools_s / python_s:.1f}; "
            f"its decode_message alone on parsed frames {decode_only_s:.1f} s, {decode_only_s / python_s:.1f} x acq.decode's whole job; "
            f"python-can's LogReader with cantools' decode {python_can_s:.1f} s, {python_can_s / python_s:.1f} x acq.decode (python-can {can.__version__})"
        )

        # The goal: acq.decode at least 50 x the notebook's pair.
        if python_can_s / python_s < GOAL:
            print(f"python_decode: {python_can_s / python_s:.1f} x python-can with cantools, below the goal of {GOAL} x")
            sys.exit(1)


if __name__ == "__main__":
    main()
