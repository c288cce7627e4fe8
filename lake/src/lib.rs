//! A test campaign as one dataset: every session and logger file of a
//! campaign decoded into a lake of plain Parquet files, partitioned the
//! Hive way, that DataFusion, DuckDB, Polars, pyarrow and Spark read as
//! they are.
//!
//! ```text
//! LAKE/
//!   samples/device=D/sensor=S/date=YYYY-MM-DD/<source id>.parquet
//!   holds/device=D/<source id>.parquet
//!   measured/device=D/<source id>.parquet
//!   _manifest/<source id>.json     one per source: its hash, what it became
//!   _tmp/                          files being written (engines skip `_`)
//!   _slurm/<slice>/                a backlog's jobs ([`backlog`]): script, list, output
//! ```
//!
//! Why this layout ([`layout`]): a campaign is asked about one machine, one
//! signal, a span of days; those are the partitions, so an engine opens
//! only the files of the signals and days a query names. Within a file the
//! rows are sorted by time and every row group and page carries min/max
//! statistics, so a time range prunes the rest. One file per source and
//! partition, named by the source's id, makes an ingest idempotent: a
//! source ingested again replaces its own files and nothing else.
//!
//! Safety ([`ingest`]): every file is written under `_tmp/` and published
//! by a rename, complete or not at all; a source's manifest entry is
//! published last, so a source without one is ingested again from the
//! start, and a source is never modified.

pub mod backlog;
pub mod ingest;
pub mod layout;
pub mod manifest;
pub mod publish;
pub mod query;
