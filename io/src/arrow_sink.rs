//! Where a table goes when its reader takes Arrow itself (the Python
//! package), instead of a file: [`ArrowSink`].

use acq_error::Result;

/// What an Arrow table is made of, for a crate that does not name Arrow.
pub use arrow_array::RecordBatch as ArrowBatch;
pub use arrow_schema::SchemaRef as ArrowSchema;

/// Where a table goes as Arrow: its schema once, before any row, then each
/// record batch as it is made (at most
/// [`BATCH_ROWS`](crate::parquet_table::BATCH_ROWS) rows). An error from
/// either (the reader went away) stops the work that fills the table.
pub trait ArrowSink: Send {
    fn schema(&mut self, schema: ArrowSchema) -> Result<()>;
    fn batch(&mut self, batch: ArrowBatch) -> Result<()>;
}
