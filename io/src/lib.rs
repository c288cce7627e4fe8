//! Files in and out, the ground floor every other `acq` stage stands on.
//!
//! - [`arrow_sink`]: a table handed over as Arrow record batches as it is
//!   made, for a reader that takes Arrow itself (the Python package).
//! - [`input`]: logs and rig files opened by name (`-` is stdin), the bad-line
//!   policy, small CSV tables read with file and line in every message.
//! - [`output`]: where results go; a file appears under its name only when
//!   complete (`NAME.partial`, renamed at the end).
//! - [`parquet_table`]: the same tables as Apache Parquet (`-o x.parquet`),
//!   streamed, with units in the column metadata and time as a timestamp.
//! - [`session`]: the session directory a recording leaves (`session.toml`,
//!   raw logs), read by the offline analysis and written by the recorder.
//! - [`shunt_record`]: a session's `shunt.toml`, each strain channel's
//!   shunt check and the gain it corrects.
//! - [`zero_record`]: a session's `zero.toml`, each channel's reading at
//!   rest before (and after) the test.
//!
//! Depends only on `acq-error`, `acq-can` and `acq-rig` (log and rig
//! formats); never on acquisition, analysis, twins, calibration or reports.

pub mod arrow_sink;
pub mod input;
pub mod output;
mod parquet_columns;
pub mod parquet_table;
pub mod session;
pub mod shunt_record;
pub mod zero_record;
