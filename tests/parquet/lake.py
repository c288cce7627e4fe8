"""The lake as three engines read it: pyarrow.dataset, Polars and DuckDB,
each with Hive partitioning. Prints JSON: per engine, the samples' rows
and value sums per (device, source_file, sensor), and the row counts of the
holds and measured tables; whether every samples file is sorted by time
(pyarrow, file by file); and the files Spark 4.0's reader would refuse
(a BYTE_STREAM_SPLIT column, a TIMESTAMP(NANOS) one)."""
import glob
import json
import sys

import duckdb
import polars as pl
import pyarrow.compute as pc
import pyarrow.dataset as ds
import pyarrow.parquet as pq

lake = sys.argv[1]
keys = ["device", "source_file", "sensor"]
out = {}


def rows_of(triples):
    return sorted([str(d), str(f), str(s), int(n), float(v or 0.0)] for d, f, s, n, v in triples)


samples = ds.dataset(f"{lake}/samples", format="parquet", partitioning="hive")
table = samples.to_table()
for key in ["source_file"]:
    table = table.set_column(table.schema.get_field_index(key), key, pc.cast(table[key], "string"))
grouped = table.group_by(keys).aggregate([("time", "count"), ("value", "sum")]).to_pylist()
out["pyarrow"] = {
    "samples": rows_of((g["device"], g["source_file"], g["sensor"], g["time_count"], g["value_sum"]) for g in grouped),
    "holds": ds.dataset(f"{lake}/holds", format="parquet", partitioning="hive").count_rows(),
    "measured": ds.dataset(f"{lake}/measured", format="parquet", partitioning="hive").count_rows(),
}

frame = (
    pl.scan_parquet(f"{lake}/samples/**/*.parquet", hive_partitioning=True)
    .with_columns(pl.col("source_file").cast(pl.String))
    .group_by(keys)
    .agg(pl.len().alias("rows"), pl.col("value").sum().alias("sum"))
    .collect()
)
out["polars"] = {
    "samples": rows_of(frame.select(keys + ["rows", "sum"]).iter_rows()),
    "holds": pl.scan_parquet(f"{lake}/holds/**/*.parquet", hive_partitioning=True).select(pl.len()).collect().item(),
    "measured": pl.scan_parquet(f"{lake}/measured/**/*.parquet", hive_partitioning=True).select(pl.len()).collect().item(),
}

con = duckdb.connect()
read = lambda t: f"read_parquet('{lake}/{t}/**/*.parquet', hive_partitioning = true)"
out["duckdb"] = {
    "samples": rows_of(con.sql(f"SELECT device, source_file, sensor, count(*), sum(value) FROM {read('samples')} GROUP BY ALL").fetchall()),
    "holds": con.sql(f"SELECT count(*) FROM {read('holds')}").fetchone()[0],
    "measured": con.sql(f"SELECT count(*) FROM {read('measured')}").fetchone()[0],
}

unsorted = []
for fragment in samples.get_fragments():
    times = pq.read_table(fragment.path, columns=["time"])["time"].combine_chunks()
    if len(times) > 1 and pc.any(pc.less(times.slice(1), times.slice(0, len(times) - 1))).as_py():
        unsorted.append(fragment.path)
out["unsorted_files"] = unsorted
spark_refuses = []
for path in sorted(glob.glob(f"{lake}/*/**/*.parquet", recursive=True)):
    metadata = pq.ParquetFile(path).metadata
    encodings = {
        encoding
        for group in range(metadata.num_row_groups)
        for column in range(metadata.num_columns)
        for encoding in metadata.row_group(group).column(column).encodings
    }
    nanos = [f.name for f in pq.read_schema(path) if str(f.type).startswith("timestamp[ns")]
    if "BYTE_STREAM_SPLIT" in encodings or nanos:
        spark_refuses.append([path, sorted(encodings), nanos])
out["spark_refuses"] = spark_refuses
for table in ["samples", "holds", "measured"]:
    con.sql(f"CREATE VIEW {table} AS SELECT * FROM {read(table)}")
out["queries"] = [[list(map(str, row)) for row in con.sql(sql).fetchall()] for sql in sys.argv[2:]]
print(json.dumps(out))
