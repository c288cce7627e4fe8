#!/usr/bin/env python3
"""Checks a Parquet table acq wrote against the CSV acq wrote for the same
command, as two readers a test engineer's colleagues use would see it:
pyarrow (behind pandas, DuckDB's Arrow path and Spark's Arrow bridge) and
polars (its own Parquet reader, written independently in Rust).

    compare.py TABLE.parquet TABLE.csv absolute|relative

- the column names are the CSV header's, in order;
- every cell equals the CSV's: floats bit for bit (the CSV holds the
  shortest text that reads back as the same double), an empty cell is null,
  a `_gap` 0/1 is a boolean, text is the same text;
- a time column is a UTC nanosecond timestamp: `absolute` means it equals
  the CSV's seconds since the epoch (decode), `relative` that it equals the
  first row's instant plus the CSV's seconds from the start (align) — both
  to the nanosecond;
- a column named `name [unit]` carries `unit` in its field metadata;
- polars reads the same values as pyarrow.

Prints `rows R columns C nulls N` and exits 0, or names the first mismatch
(row, column, both values) and exits 1.
"""

import csv
import struct
import sys
from decimal import Decimal

import polars as pl
import pyarrow as pa
import pyarrow.parquet as pq


def fail(message):
    print(message, file=sys.stderr)
    sys.exit(1)


def ns_of_seconds(text):
    return int(Decimal(text) * 1_000_000_000)


def main():
    parquet_path, csv_path, time_mode = sys.argv[1:4]
    table = pq.read_table(parquet_path)
    with open(csv_path, newline="") as f:
        lines = [line for line in f if not line.startswith("#")]
    rows = list(csv.reader(lines))
    header, body = rows[0], rows[1:]
    names = table.schema.names
    if names != header:
        fail(f"columns {names} != CSV header {header}")
    if table.num_rows != len(body):
        fail(f"{table.num_rows} rows != {len(body)} CSV rows")

    nulls = 0
    first_time_ns = None
    for c, name in enumerate(names):
        field = table.schema.field(name)
        metadata = {k.decode(): v.decode() for k, v in (field.metadata or {}).items()}
        if name.endswith("]") and " [" in name:
            unit = name[name.rindex(" [") + 2 : -1]
            if unit and metadata.get("unit") != unit:
                fail(f"column {name}: unit metadata {metadata} != {unit!r}")
        column = table.column(name)
        kind = field.type
        if pa.types.is_timestamp(kind):
            if kind.unit != "ns" or kind.tz != "UTC":
                fail(f"column {name}: {kind}, expected timestamp[ns, tz=UTC]")
            values = column.cast(pa.int64()).to_pylist()
        elif pa.types.is_dictionary(kind):
            values = column.cast(pa.string()).to_pylist()
        else:
            values = column.to_pylist()
        for r, (value, row) in enumerate(zip(values, body)):
            text = row[c]
            where = f"row {r + 1}, column {name}: parquet {value!r}, CSV {text!r}"
            if value is None:
                nulls += 1
                if text != "":
                    fail(where)
            elif pa.types.is_timestamp(kind):
                if time_mode == "absolute":
                    ok = value == ns_of_seconds(text)
                else:
                    if first_time_ns is None:
                        first_time_ns = value - ns_of_seconds(body[0][c])
                    ok = value - first_time_ns == ns_of_seconds(text)
                if not ok:
                    fail(where)
            elif pa.types.is_boolean(kind):
                if text != ("1" if value else "0"):
                    fail(where)
            elif pa.types.is_floating(kind):
                expected = float(text)
                same = struct.pack("<d", value) == struct.pack("<d", expected) or (
                    value != value and expected != expected
                )
                if not same:
                    fail(where)
            elif pa.types.is_integer(kind):
                if value != int(text):
                    fail(where)
            else:
                if value != text:
                    fail(where)

    # polars, its own reader, sees the same table.
    frame = pl.read_parquet(parquet_path)
    if frame.columns != names or frame.height != table.num_rows:
        fail(f"polars: {frame.columns} x {frame.height}")
    for name in names:
        series = frame[name]
        if series.dtype == pl.Datetime:
            theirs = series.cast(pl.Int64).to_list()
            ours = table.column(name).cast(pa.int64()).to_pylist()
        elif series.dtype == pl.Categorical or series.dtype == pl.String:
            theirs = series.cast(pl.String).to_list()
            ours = table.column(name).cast(pa.string()).to_pylist()
        else:
            theirs = series.to_list()
            ours = table.column(name).to_pylist()
        if theirs != ours:
            fail(f"polars differs from pyarrow in column {name}")

    print(f"rows {table.num_rows} columns {len(names)} nulls {nulls}")


if __name__ == "__main__":
    main()
