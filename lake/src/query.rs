//! SQL over the lake with Apache DataFusion: the lake's tables registered
//! by name (`samples`, `holds`, `measured`), their Hive partitions as
//! columns, and the result streamed out as CSV or Parquet.
//!
//! The public functions block on a runtime of their own. DataFusion's
//! planner and streams are async, and an async body is compiled in the
//! crate that polls it: polled from the binary, the SQL front end (about
//! half of the binary's code) was compiled there, last and alone, on the
//! release build's critical path.

use std::path::Path;
use std::sync::Arc;

use acq_error::{AcqError, Result};
use datafusion::arrow::array::RecordBatch;
use datafusion::arrow::csv::WriterBuilder;
use datafusion::arrow::datatypes::DataType;
use datafusion::datasource::file_format::parquet::ParquetFormat;
use datafusion::datasource::listing::ListingOptions;
use datafusion::prelude::SessionContext;
use futures::StreamExt;
use parquet::arrow::ArrowWriter;

use acq_analysis::extract::measured::MEASURED_HEADER;

use crate::layout::{HOLDS, MEASURED, SAMPLES};

/// The partition columns of each table, in path order.
fn partitions(table: &str) -> &'static [&'static str] {
    match table {
        SAMPLES => &["device", "sensor", "date"],
        _ => &["device"],
    }
}

/// A DataFusion session with the lake's tables registered: those that hold
/// at least one file.
async fn session(lake: &Path) -> Result<SessionContext> {
    let lake = std::fs::canonicalize(lake).map_err(|e| {
        AcqError::Config(format!(
            "{}: no lake here ({e}); make one with acq lake ingest",
            lake.display()
        ))
    })?;
    let context = SessionContext::new();
    let mut registered = 0;
    for table in [SAMPLES, HOLDS, MEASURED] {
        let dir = lake.join(table);
        if !dir.is_dir() {
            continue;
        }
        let options = ListingOptions::new(Arc::new(ParquetFormat::default()))
            .with_file_extension(".parquet")
            .with_table_partition_cols(
                partitions(table)
                    .iter()
                    .map(|name| (name.to_string(), DataType::Utf8))
                    .collect(),
            );
        let url = format!("{}/", dir.display());
        context
            .register_listing_table(table, &url, options, None, None)
            .await
            .map_err(|e| AcqError::Config(format!("{}: {e}", dir.display())))?;
        registered += 1;
    }
    if registered == 0 {
        return Err(AcqError::Config(format!(
            "{}: no table of a lake (samples, holds, measured); make one with acq lake ingest",
            lake.display()
        )));
    }
    Ok(context)
}

/// Where a query's rows go.
pub enum Sink<'a> {
    Csv(&'a mut dyn std::io::Write),
    Parquet(&'a mut (dyn std::io::Write + Send)),
}

/// Runs `sql` on the lake and streams its rows into `sink` (CSV with a
/// header, or Parquet); returns the rows written.
pub fn query(lake: &Path, sql: &str, sink: Sink<'_>) -> Result<u64> {
    runtime()?.block_on(query_rows(lake, sql, sink))
}

/// DataFusion's runtime: two workers, as many as the scans use.
fn runtime() -> Result<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(|e| AcqError::io("starting the async runtime", e))
}

async fn query_rows(lake: &Path, sql: &str, sink: Sink<'_>) -> Result<u64> {
    let context = session(lake).await?;
    let tables = tables_said(&context).await;
    let sql_error = |e: datafusion::error::DataFusionError| {
        AcqError::Config(format!("SQL: {e}\nthe lake's tables: {tables}"))
    };
    let frame = context.sql(sql).await.map_err(sql_error)?;
    let schema = Arc::new(frame.schema().as_arrow().clone());
    let mut stream = frame.execute_stream().await.map_err(sql_error)?;
    let mut rows = 0u64;
    let mut next = async || -> Result<Option<RecordBatch>> {
        match stream.next().await {
            Some(batch) => batch.map(Some).map_err(sql_error),
            None => Ok(None),
        }
    };
    match sink {
        Sink::Csv(out) => {
            let mut writer = WriterBuilder::new().with_header(true).build(out);
            let mut wrote_any = false;
            while let Some(batch) = next().await? {
                rows += batch.num_rows() as u64;
                writer.write(&batch).map_err(write_error)?;
                wrote_any = true;
            }
            if !wrote_any {
                // The header of an empty result.
                writer
                    .write(&RecordBatch::new_empty(schema))
                    .map_err(write_error)?;
            }
        }
        Sink::Parquet(out) => {
            let mut writer = ArrowWriter::try_new(out, schema, None)
                .map_err(|e| AcqError::Config(format!("writing Parquet: {e}")))?;
            while let Some(batch) = next().await? {
                rows += batch.num_rows() as u64;
                writer
                    .write(&batch)
                    .map_err(|e| AcqError::Config(format!("writing Parquet: {e}")))?;
            }
            writer
                .close()
                .map_err(|e| AcqError::Config(format!("writing Parquet: {e}")))?;
        }
    }
    Ok(rows)
}

fn write_error(e: datafusion::arrow::error::ArrowError) -> AcqError {
    match e {
        datafusion::arrow::error::ArrowError::IoError(what, source) => AcqError::io(what, source),
        other => AcqError::Config(format!("writing CSV: {other}")),
    }
}

/// The lake's tables and their columns, `samples(time, value, ...); ...`,
/// for a message about a misspelt name.
async fn tables_said(context: &SessionContext) -> String {
    let mut tables: Vec<String> = Vec::new();
    for name in [SAMPLES, HOLDS, MEASURED] {
        if let Ok(provider) = context.table_provider(name).await {
            let columns: Vec<String> = provider
                .schema()
                .fields()
                .iter()
                .map(|f| f.name().clone())
                .collect();
            tables.push(format!("{name}({})", columns.join(", ")));
        }
    }
    tables.join("; ")
}

/// The measured values of the lake that `predicate` (SQL over the
/// `measured` table's columns) selects, in the columns of `acq extract`'s
/// file led by `session`: what `acq calibrate` reads as it reads one
/// session's, each window then named `session/window`. In each source's
/// order, sources by session.
pub fn extract(lake: &Path, predicate: Option<&str>, sink: Sink<'_>) -> Result<u64> {
    let columns: Vec<String> = std::iter::once("session")
        .chain(MEASURED_HEADER.split(','))
        .map(|column| format!("\"{column}\""))
        .collect();
    let filter = predicate.map_or(String::new(), |p| format!(" WHERE {p}"));
    let sql = format!(
        "SELECT {} FROM measured{filter} ORDER BY session, source_file, \"row\"",
        columns.join(", ")
    );
    query(lake, &sql, sink)
}
