#!/usr/bin/env python3
"""Decoding vectors for every DBC of the opendbc package, made with cantools.

Run by can/tests/it/opendbc.rs in a scratch virtualenv (cantools 45.1.0,
opendbc 0.3.1, never dependencies of acq):

    python vectors.py OUT_DIR

What it does
------------
Takes every ``.dbc`` file the installed opendbc package ships (under its
package directory, generator sources included) and every DBC its generator
makes (``opendbc.get_generated_dbcs()``, written to ``OUT_DIR/generated/``
so acq reads the same text), and loads each with cantools as
``load_file(path)`` does by default: strict (overlapping signals, signals
beyond their message and unused ``VAL_`` lines are errors), cp1252 text.

For every message of a loaded (or lax, below) DBC it makes a few frames of the message's
length from a random generator seeded by the file's name (so the vectors do
not change when opendbc adds a file): all 0x00, all 0xFF, ``RANDOM_FRAMES``
random payloads and, for a multiplexed message, one random payload per
page of every multiplexor (up to ``MAX_PAGES`` pages each, the parents'
switches set so the page is reached) and one with a switch value no page
has. Each is decoded as ``tests/golden/make_golden.py`` does::

    db.decode_message(frame_id, data, decode_choices=False, scaling=True,
                      force_extended_id=message.is_extended_frame)

Output: ``OUT_DIR/vectors.txt``, one record per line, fields separated by a
tab (names and values hold none):

    D  path  name  status  why            a DBC: the file to read, the name
                                          shown (relative to the package),
                                          loaded, refused or lax (refused
                                          in strict mode, loaded with
                                          strict=False), and cantools'
                                          error if refused
    M  id_hex  extended  name  signal...  a message of the last D and its
                                          signals, in cantools' order
    F  data_hex  value...                 a frame: repr() of each signal's
                                          value, '-' when not decoded
    L  index=label...                     the value-table labels of the
                                          frame before (decode_choices=True),
                                          by the index of the signal in M
    E  data_hex  error                    a frame cantools refuses
"""

import os
import random
import sys
import zlib

from importlib.metadata import version

import cantools
import opendbc
from cantools.database.errors import DecodeError
from cantools.database.namedsignalvalue import NamedSignalValue

CANTOOLS_VERSION = "45.1.0"
OPENDBC_VERSION = "0.3.1"
RANDOM_FRAMES = 6
MAX_PAGES = 16


def dbc_files(out_dir):
    """(absolute path, name shown) of every DBC to check, sorted."""
    root = os.path.dirname(os.path.abspath(opendbc.__file__))
    found = []
    for directory, _, names in os.walk(root):
        for name in names:
            if name.endswith(".dbc"):
                path = os.path.join(directory, name)
                found.append((path, os.path.relpath(path, root)))
    generated_dir = os.path.join(out_dir, "generated")
    os.makedirs(generated_dir, exist_ok=True)
    for name, text in opendbc.get_generated_dbcs().items():
        path = os.path.join(generated_dir, name + ".dbc")
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)
        found.append((path, "generated/" + name + ".dbc"))
    return sorted(found, key=lambda item: item[1])


def bit_positions(signal):
    """Bit positions (byte*8 + bit) from the raw value's LSB to its MSB."""
    if signal.byte_order == "little_endian":
        return [signal.start + i for i in range(signal.length)]
    pos, msb_first = signal.start, []
    for _ in range(signal.length):
        msb_first.append(pos)
        pos = pos + 15 if pos % 8 == 0 else pos - 1
    return list(reversed(msb_first))


def put_raw(buf, signal, raw):
    raw &= (1 << signal.length) - 1
    for i, pos in enumerate(bit_positions(signal)):
        byte, bit = divmod(pos, 8)
        if byte >= len(buf):
            continue
        if (raw >> i) & 1:
            buf[byte] |= 1 << bit
        else:
            buf[byte] &= ~(1 << bit) & 0xFF


def raw_for_page(signal, page):
    """The raw value whose scaled value cantools truncates to `page`
    (cantools selects a page by int() of the scaled multiplexor)."""
    if signal.is_float:
        return None
    raw = round((page - signal.offset) / signal.scale) if signal.scale else page
    return raw


def pages(message, mux):
    """Values of `mux` that select a page: its children's ids and its
    value-table keys (cantools' Message._create_codec)."""
    ids = set()
    for s in message.signals:
        if s.multiplexer_signal == mux.name and s.multiplexer_ids:
            ids.update(s.multiplexer_ids)
    ids.update((mux.choices or {}).keys())
    return sorted(ids)


def select(buf, message, signal, page):
    """Set `signal` (a multiplexor) to `page` and its ancestors so it is read."""
    raw = raw_for_page(signal, page)
    if raw is not None:
        put_raw(buf, signal, raw)
    if signal.multiplexer_signal and signal.multiplexer_ids:
        parent = message.get_signal_by_name(signal.multiplexer_signal)
        select(buf, message, parent, sorted(signal.multiplexer_ids)[0])


def frames(rng, message):
    n = message.length
    out = [bytes(n), b"\xff" * n]

    def random_bytes():
        return bytearray(rng.getrandbits(8) for _ in range(n))

    out += [bytes(random_bytes()) for _ in range(RANDOM_FRAMES)]
    for mux in message.signals:
        if not mux.is_multiplexer:
            continue
        values = pages(message, mux)
        for page in values[:MAX_PAGES]:
            buf = random_bytes()
            select(buf, message, mux, page)
            out.append(bytes(buf))
        if values:
            buf = random_bytes()
            select(buf, message, mux, max(values) + 1)
            out.append(bytes(buf))
    unique = []
    for data in out:
        if data not in unique:
            unique.append(data)
    return unique


def main(argv):
    if len(argv) != 1:
        raise SystemExit("usage: vectors.py OUT_DIR")
    if cantools.__version__ != CANTOOLS_VERSION:
        raise SystemExit(f"expected cantools {CANTOOLS_VERSION}, found {cantools.__version__}")
    if version("opendbc") != OPENDBC_VERSION:
        raise SystemExit(f"expected opendbc {OPENDBC_VERSION}, found {version('opendbc')}")
    out_dir = os.path.abspath(argv[0])
    os.makedirs(out_dir, exist_ok=True)
    lines = []
    counts = {"loaded": 0, "refused": 0, "lax": 0, "labels": 0, "frames": 0, "values": 0}
    for path, shown in dbc_files(out_dir):
        try:
            db = cantools.database.load_file(path, strict=True)
            lines.append(f"D\t{path}\t{shown}\tloaded\t")
            counts["loaded"] += 1
        except Exception as exc:  # cantools raises several kinds
            reason = " ".join(str(exc).split())
            counts["refused"] += 1
            # Refused only by strict checks (overlapping signals, a signal
            # beyond its message, unused VAL_): cantools still decodes it
            # with strict=False, so its frames are compared too, though acq
            # need not load it.
            try:
                db = cantools.database.load_file(path, strict=False)
            except Exception:
                lines.append(f"D\t{path}\t{shown}\trefused\t{type(exc).__name__}: {reason}")
                continue
            lines.append(f"D\t{path}\t{shown}\tlax\t{type(exc).__name__}: {reason}")
            counts["lax"] += 1
        rng = random.Random(zlib.crc32(shown.encode()))
        for message in db.messages:
            names = [s.name for s in message.signals]
            ext = 1 if message.is_extended_frame else 0
            lines.append("\t".join(["M", f"{message.frame_id:X}", str(ext), message.name] + names))
            for data in frames(rng, message):
                try:
                    decoded = db.decode_message(message.frame_id, data,
                                                decode_choices=False, scaling=True,
                                                force_extended_id=message.is_extended_frame)
                except DecodeError as exc:
                    lines.append(f"E\t{data.hex().upper()}\t{exc}")
                    continue
                values = []
                for name in names:
                    value = decoded.get(name)
                    if value is None:
                        values.append("-")
                    elif isinstance(value, bool) or not isinstance(value, (int, float)):
                        raise SystemExit(f"{shown}: {message.name}.{name}: unexpected {value!r}")
                    else:
                        values.append(repr(value))
                        counts["values"] += 1
                lines.append("\t".join(["F", data.hex().upper()] + values))
                counts["frames"] += 1
                # Value-table labels: decode_choices=True names a raw value
                # its VAL_ entry.
                labelled = db.decode_message(message.frame_id, data,
                                             decode_choices=True, scaling=True,
                                             force_extended_id=message.is_extended_frame)
                labels = [f"{names.index(name)}={value}"
                          for name, value in labelled.items()
                          if isinstance(value, (NamedSignalValue, str))]
                if labels:
                    lines.append("\t".join(["L"] + labels))
                    counts["labels"] += len(labels)
    with open(os.path.join(out_dir, "vectors.txt"), "w", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")
    print(f"cantools {cantools.__version__}, opendbc {OPENDBC_VERSION}: "
          f"{counts['loaded']} DBCs loaded, {counts['refused']} refused "
          f"({counts['lax']} of them load with strict=False), "
          f"{counts['frames']} frames, {counts['values']} values, {counts['labels']} labels")


if __name__ == "__main__":
    main(sys.argv[1:])
