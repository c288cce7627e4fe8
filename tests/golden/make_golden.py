#!/usr/bin/env python3
"""Generate golden DBC decoding vectors with the Python reference `cantools`.

What it does
------------
Loads ``golden.dbc`` (next to this file) with cantools in strict mode and, for
every message, builds a deterministic set of payloads of the message's length
(fixed random seed):

* all 0x00, all 0xFF, 0x55.., 0xAA.., and a 0x0F/0xF0 byte pattern;
* per signal, on an all-0x00 background: raw = all ones, raw = only the top
  bit set (the signed minimum for signed signals); on an all-0xFF background:
  raw = 0 (the signal's neighbours are all ones);
* per signal with a value table: one payload per ``VAL_`` raw key (random
  background);
* per IEEE float signal: payloads whose float bits hold normal finite numbers
  (decimal-looking values and random normal bit patterns), plus 0.0, -0.0,
  1.0, the smallest/largest normal, the smallest subnormal, and the
  non-finite cases NaN, +inf, -inf.  Non-finite results are "marked" by their
  value: every row whose value is ``nan``, ``inf`` or ``-inf`` comes from such
  a payload (or from an all-0xFF float, which is a NaN);
* random payloads (random bytes) up to ~60 payloads per message.

For multiplexed signals the multiplexor is set to the signal's page so the
signal is actually decoded; random payloads of the multiplexed message get a
valid page most of the time, and a few payloads carry an unknown multiplexor
value on purpose (cantools raises ``DecodeError`` for those; they are listed
in ``cantools_errors.csv`` and produce no value rows).

Bits are placed by a small independent bit setter (``put_raw``); every
constructed payload is checked by decoding it back with cantools
(``scaling=False``) so the setter and cantools agree.

Each payload is decoded with::

    db.decode_message(frame_id, data, decode_choices=False, scaling=True,
                      force_extended_id=<message is extended>)

(``force_extended_id`` is needed because cantools treats an integer id
<= 0x7FF as a standard id, and ``ExtLowId`` is the extended id 0x123.)

Outputs (next to this file):

* ``cantools_vectors.csv``  ``can_id,extended,data,message,signal,value``
  one row per signal cantools returns; value is Python ``repr()`` of the
  decoded value (int stays int, float is the shortest round-trip repr).
* ``cantools_labels.csv``   ``can_id,data,signal,label``
  decoded again with ``decode_choices=True``; one row per signal whose result
  is a value-table label.
* ``cantools_errors.csv``   ``can_id,extended,data,message,error``
  payloads cantools refuses to decode (unknown multiplexor value).

can_id is ``0x`` + uppercase hex without leading zeros (without the
0x80000000 DBC flag), data is the payload as uppercase hex, no separators.

Rerun
-----
::

    python3 -m venv /tmp/golden-venv
    /tmp/golden-venv/bin/pip install cantools==45.1.0
    /tmp/golden-venv/bin/python tests/golden/make_golden.py

Generated with cantools 45.1.0 (Python 3.11).  The script refuses to run
with another cantools version unless ``--any-version`` is given, so that the
committed vectors always say which reference produced them.
"""

import csv
import math
import os
import random
import struct
import sys

import cantools
from cantools.database.errors import DecodeError
from cantools.database.namedsignalvalue import NamedSignalValue

CANTOOLS_VERSION = "45.1.0"
SEED = 0xAC0_601D
TARGET_PAYLOADS = 60
MIN_RANDOM = 20
MIN_RANDOM_MUX = 50  # multiplexed messages: enough random frames per page

HERE = os.path.dirname(os.path.abspath(__file__))
DBC_PATH = os.path.join(HERE, "golden.dbc")
VECTORS_PATH = os.path.join(HERE, "cantools_vectors.csv")
LABELS_PATH = os.path.join(HERE, "cantools_labels.csv")
ERRORS_PATH = os.path.join(HERE, "cantools_errors.csv")


# --------------------------------------------------------------------------
# Bit placement (independent of cantools; cross-checked against it below).
# --------------------------------------------------------------------------

def bit_positions(signal):
    """Physical bit positions (byte*8 + bit, bit 0 = LSB of the byte),
    ordered from the raw value's LSB to its MSB."""
    if signal.byte_order == "little_endian":
        return [signal.start + i for i in range(signal.length)]
    # Motorola: start is the MSB; walk down inside a byte, then to bit 7 of
    # the next byte.
    pos = signal.start
    msb_first = []
    for _ in range(signal.length):
        msb_first.append(pos)
        pos = pos + 15 if pos % 8 == 0 else pos - 1
    return list(reversed(msb_first))


def put_raw(buf, signal, raw):
    """Write the raw integer pattern `raw` (two's complement for negatives)
    into bytearray `buf` at the signal's position."""
    raw &= (1 << signal.length) - 1
    for i, pos in enumerate(bit_positions(signal)):
        byte, bit = divmod(pos, 8)
        if (raw >> i) & 1:
            buf[byte] |= 1 << bit
        else:
            buf[byte] &= ~(1 << bit) & 0xFF


def float_bits(signal, value):
    if signal.length == 32:
        return struct.unpack(">I", struct.pack(">f", value))[0]
    return struct.unpack(">Q", struct.pack(">d", value))[0]


def bits_to_float(length, bits):
    if length == 32:
        return struct.unpack(">f", struct.pack(">I", bits))[0]
    return struct.unpack(">d", struct.pack(">Q", bits))[0]


# --------------------------------------------------------------------------
# Payload generation
# --------------------------------------------------------------------------

def mux_parent(message, signal):
    if signal.multiplexer_ids is None:
        return None
    return message.get_signal_by_name(signal.multiplexer_signal)


def page_raw(mux, page):
    """The raw multiplexor value that selects `page`: cantools selects by
    int() of the scaled value, so a scaled multiplexor needs page/factor."""
    return round((page - mux.offset) / mux.scale)


def set_page(buf, message, signal):
    """Make sure a multiplexed signal's page is selected."""
    parent = mux_parent(message, signal)
    if parent is not None:
        put_raw(buf, parent, page_raw(parent, signal.multiplexer_ids[0]))
        set_page(buf, message, parent)
    elif not signal.is_multiplexer:
        # Plain signal of a multiplexed message: select the first page so
        # the frame decodes (cantools refuses unknown multiplexor values).
        for mux in message.signals:
            if mux.is_multiplexer and mux_parent(message, mux) is None:
                pages = mux_pages(message, mux)
                if pages:
                    put_raw(buf, mux, page_raw(mux, pages[0]))


def mux_pages(message, mux):
    """Multiplexor values cantools accepts: those that select at least one
    signal, and the multiplexor's value-table keys (a page may hold no
    signal). Empty: the switch selects nothing, so any value decodes."""
    pages = {i for s in message.signals
             if s.multiplexer_signal == mux.name
             for i in (s.multiplexer_ids or [])}
    pages.update((mux.choices or {}).keys())
    return sorted(pages)


def random_normal_bits(rng, length):
    if length == 32:
        exp = rng.randint(1, 254)
        return (rng.getrandbits(1) << 31) | (exp << 23) | rng.getrandbits(23)
    exp = rng.randint(1, 2046)
    return (rng.getrandbits(1) << 63) | (exp << 52) | rng.getrandbits(52)


def float_specials(length):
    """(bits, is_finite) pairs for special float values."""
    if length == 32:
        return [
            (0x00000000, True),   # 0.0
            (0x80000000, True),   # -0.0
            (0x3F800000, True),   # 1.0
            (0x00800000, True),   # smallest normal
            (0x7F7FFFFF, True),   # largest finite
            (0x00000001, True),   # smallest subnormal
            (0x7FC00000, False),  # NaN
            (0x7F800000, False),  # +inf
            (0xFF800000, False),  # -inf
        ]
    return [
        (0x0000000000000000, True),
        (0x8000000000000000, True),
        (0x3FF0000000000000, True),
        (0x0010000000000000, True),
        (0x7FEFFFFFFFFFFFFF, True),
        (0x0000000000000001, True),
        (0x7FF8000000000000, False),
        (0x7FF0000000000000, False),
        (0xFFF0000000000000, False),
    ]


def build_payloads(rng, message):
    n = message.length
    payloads = []  # list of (bytes, expected {signal_name: raw} or None)

    def add(buf, expect=None):
        payloads.append((bytes(buf), expect or {}))

    def rand_buf():
        return bytearray(rng.getrandbits(8) for _ in range(n))

    # Whole-payload patterns.
    for pat in (b"\x00", b"\xFF", b"\x55", b"\xAA", b"\x0F\xF0"):
        add(bytearray((pat * n)[:n]))

    for sig in message.signals:
        ones = (1 << sig.length) - 1
        top = 1 << (sig.length - 1)
        # Signal all ones / top bit only, on a zero background.
        for raw in (ones, top):
            buf = bytearray(n)
            set_page(buf, message, sig)
            put_raw(buf, sig, raw)
            add(buf, {sig.name: raw})
        # Signal zero, neighbours all ones.
        buf = bytearray(b"\xFF" * n)
        set_page(buf, message, sig)
        put_raw(buf, sig, 0)
        add(buf, {sig.name: 0})
        # One payload per value-table key.
        if sig.choices:
            for key in sig.choices:
                buf = rand_buf()
                set_page(buf, message, sig)
                put_raw(buf, sig, key)
                add(buf, {sig.name: key})
        # Float signals: normal finite values plus specials.
        if sig.is_float:
            values = []
            for _ in range(4):
                values.append(round(rng.uniform(-10000.0, 10000.0), rng.randint(0, 4)))
            values.append(116.89)
            bit_list = [float_bits(sig, v) for v in values]
            bit_list += [random_normal_bits(rng, sig.length) for _ in range(4)]
            bit_list += [b for b, _finite in float_specials(sig.length)]
            for bits in bit_list:
                buf = rand_buf()
                set_page(buf, message, sig)
                put_raw(buf, sig, bits)
                add(buf, {sig.name: bits})

    # Multiplexed message: deliberately unknown multiplexor values.
    muxers = [s for s in message.signals if s.is_multiplexer]
    for mux in muxers:
        pages = mux_pages(message, mux)
        if not pages:
            continue
        for bad in (max(pages) + 1, (1 << mux.length) - 1):
            buf = rand_buf()
            put_raw(buf, mux, bad)
            add(buf)

    # Random fill.
    n_random = max(MIN_RANDOM, TARGET_PAYLOADS - len(payloads))
    if muxers:
        n_random = max(n_random, MIN_RANDOM_MUX)
    for i in range(n_random):
        buf = rand_buf()
        # Keep most random frames of a multiplexed message on a valid page
        # (every 10th one keeps its random, mostly unknown, multiplexor value).
        for mux in muxers:
            if i % 10 != 9 and mux_pages(message, mux):
                put_raw(buf, mux, page_raw(mux, rng.choice(mux_pages(message, mux))))
        add(buf)

    # Deduplicate, keeping first occurrence.
    seen = set()
    out = []
    for data, expect in payloads:
        if data not in seen:
            seen.add(data)
            out.append((data, expect))
    return out


# --------------------------------------------------------------------------
# Self-check of the bit setter against cantools.
# --------------------------------------------------------------------------

def check_raw(db, message, data, expect):
    if not expect:
        return
    # Unscaled, a scaled multiplexor selects another page (cantools uses
    # int() of the value it decoded): signals it leaves out go unchecked.
    try:
        raw = db.decode_message(message.frame_id, data, decode_choices=False,
                                scaling=False,
                                force_extended_id=message.is_extended_frame)
    except DecodeError:
        return
    for name, want in expect.items():
        if name not in raw:
            continue
        sig = message.get_signal_by_name(name)
        got = raw[name]
        if sig.is_float:
            want_f = bits_to_float(sig.length, want)
            ok = (math.isnan(got) and math.isnan(want_f)) or float_bits(sig, got) == want
        else:
            if sig.is_signed and want >= 1 << (sig.length - 1):
                want -= 1 << sig.length
            ok = got == want
        if not ok:
            raise SystemExit(f"bit setter disagrees with cantools: {message.name}.{name} "
                             f"data={data.hex()} want={want!r} got={got!r}")


# --------------------------------------------------------------------------

def main(argv):
    if cantools.__version__ != CANTOOLS_VERSION and "--any-version" not in argv:
        raise SystemExit(f"expected cantools {CANTOOLS_VERSION}, found {cantools.__version__} "
                         f"(pass --any-version to override)")

    db = cantools.database.load_file(DBC_PATH, strict=True)
    rng = random.Random(SEED)

    vec_rows, label_rows, error_rows = [], [], []
    for message in db.messages:
        can_id = f"0x{message.frame_id:X}"
        ext = 1 if message.is_extended_frame else 0
        for data, expect in build_payloads(rng, message):
            hexdata = data.hex().upper()
            try:
                decoded = db.decode_message(message.frame_id, data,
                                            decode_choices=False, scaling=True,
                                            force_extended_id=message.is_extended_frame)
            except DecodeError as exc:
                error_rows.append([can_id, ext, hexdata, message.name, str(exc)])
                continue
            check_raw(db, message, data, expect)
            for name, value in decoded.items():
                if not isinstance(value, (int, float)) or isinstance(value, bool):
                    raise SystemExit(f"unexpected type {type(value)} for {name}")
                vec_rows.append([can_id, ext, hexdata, message.name, name, repr(value)])
            labelled = db.decode_message(message.frame_id, data,
                                         decode_choices=True, scaling=True,
                                         force_extended_id=message.is_extended_frame)
            for name, value in labelled.items():
                if isinstance(value, (NamedSignalValue, str)):
                    label_rows.append([can_id, hexdata, name, str(value)])

    def write(path, header, rows):
        with open(path, "w", newline="") as f:
            w = csv.writer(f, lineterminator="\n")
            w.writerow(header)
            w.writerows(rows)

    write(VECTORS_PATH, ["can_id", "extended", "data", "message", "signal", "value"], vec_rows)
    write(LABELS_PATH, ["can_id", "data", "signal", "label"], label_rows)
    write(ERRORS_PATH, ["can_id", "extended", "data", "message", "error"], error_rows)
    print(f"cantools {cantools.__version__}: {len(vec_rows)} value rows, "
          f"{len(label_rows)} label rows, {len(error_rows)} refused payloads")


if __name__ == "__main__":
    main(sys.argv[1:])
