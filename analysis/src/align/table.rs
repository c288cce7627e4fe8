//! The aligned table as CSV: `#` comment lines (session, start, grid,
//! clock offsets), then `time_s` and per channel `name [unit]` and
//! `name_gap` (1 where the channel has no value: the cell is empty).
//!
//! Or as Parquet ([`ParquetAlignedTable`]): the same columns, `time_s` the
//! row's UTC instant, a missing value null, `name_gap` a boolean, each
//! value column's unit in its metadata, the comments in the file's.
//!
//! Or as MF4 ([`Mf4AlignedTable`]): one channel group `aligned`, a channel
//! per sensor with its unit, a gap an invalid value, the comments the data
//! group's comment.

use acq_can::dbc::push_shortest_f64;
use acq_can::log::mf4_signals::{Mf4SignalWriter, SignalChannel, SignalGroup};
use acq_error::AcqError;
use acq_io::output::{csv_field, CompleteOnlyFile, Output};
use acq_io::parquet_table::{ArrowSink, ColumnSpec, ColumnType, ParquetTable};

use super::{GridSpec, RowSink};

/// One column of the table.
#[derive(Clone, Debug)]
pub struct Column {
    pub name: String,
    pub unit: String,
}

/// Writes aligned rows as CSV.
pub struct CsvTable {
    /// `None` once finished.
    out: Option<Output>,
    rate_hz: f64,
    pub rows: u64,
}

impl CsvTable {
    /// Writes the comment lines and the header.
    pub fn new(
        mut out: Output,
        comments: &[String],
        columns: &[Column],
        rate_hz: f64,
    ) -> Result<Self, AcqError> {
        for comment in comments {
            for line in comment.lines() {
                out.buffer.extend_from_slice(b"# ");
                out.buffer.extend_from_slice(line.as_bytes());
                out.buffer.push(b'\n');
            }
        }
        out.buffer.extend_from_slice(b"time_s");
        for column in columns {
            let heading = format!("{} [{}]", column.name, column.unit);
            out.buffer.push(b',');
            out.buffer.extend_from_slice(csv_field(&heading).as_bytes());
            out.buffer.push(b',');
            out.buffer
                .extend_from_slice(csv_field(&format!("{}_gap", column.name)).as_bytes());
        }
        out.buffer.push(b'\n');
        Ok(CsvTable {
            out: Some(out),
            rate_hz,
            rows: 0,
        })
    }
}

impl RowSink for CsvTable {
    type Error = AcqError;

    fn row(&mut self, row: u64, values: &[Option<f64>]) -> Result<(), AcqError> {
        let Some(out) = self.out.as_mut() else {
            return Ok(());
        };
        let buffer = &mut out.buffer;
        push_shortest_f64(buffer, row as f64 / self.rate_hz);
        for value in values {
            buffer.push(b',');
            match value {
                Some(v) => {
                    push_shortest_f64(buffer, *v);
                    buffer.extend_from_slice(b",0");
                }
                None => buffer.extend_from_slice(b",1"),
            }
        }
        buffer.push(b'\n');
        self.rows += 1;
        out.maybe_flush()
    }

    /// Writes everything out (and gives a `.partial` file its name).
    fn finish(&mut self) -> Result<(), AcqError> {
        match self.out.take() {
            Some(out) => out.finish(),
            None => Ok(()),
        }
    }
}

/// Writes aligned rows as Parquet.
pub struct ParquetAlignedTable {
    /// `None` once finished.
    table: Option<ParquetTable>,
    /// Row times come from the grid, as the aligner computes them.
    grid: GridSpec,
}

impl ParquetAlignedTable {
    pub fn new(
        out: Output,
        comments: &[String],
        columns: &[Column],
        grid: GridSpec,
    ) -> Result<Self, AcqError> {
        Ok(ParquetAlignedTable {
            table: Some(ParquetTable::new(out, &Self::specs(columns), comments)?),
            grid,
        })
    }

    /// The same table as Arrow record batches, handed to `sink`.
    pub fn to_arrow(
        sink: Box<dyn ArrowSink>,
        comments: &[String],
        columns: &[Column],
        grid: GridSpec,
    ) -> Result<Self, AcqError> {
        Ok(ParquetAlignedTable {
            table: Some(ParquetTable::to_arrow(
                &Self::specs(columns),
                comments,
                sink,
            )?),
            grid,
        })
    }

    /// `time_s`, then per sensor its value (`NAME [UNIT]`) and gap flag.
    fn specs(columns: &[Column]) -> Vec<ColumnSpec> {
        let mut specs = vec![ColumnSpec::new("time_s", ColumnType::Time)];
        for column in columns {
            specs.push(
                ColumnSpec::new(
                    format!("{} [{}]", column.name, column.unit),
                    ColumnType::Float,
                )
                .unit(&column.unit)
                .nullable(),
            );
            specs.push(ColumnSpec::new(
                format!("{}_gap", column.name),
                ColumnType::Flag,
            ));
        }
        specs
    }
}

impl RowSink for ParquetAlignedTable {
    type Error = AcqError;

    fn row(&mut self, row: u64, values: &[Option<f64>]) -> Result<(), AcqError> {
        let Some(table) = self.table.as_mut() else {
            return Ok(());
        };
        table.time_ns(0, self.grid.time_ns(row));
        for (channel, value) in values.iter().enumerate() {
            table.float(1 + 2 * channel, *value);
            table.flag(2 + 2 * channel, value.is_none());
        }
        table.end_row()
    }

    fn finish(&mut self) -> Result<(), AcqError> {
        match self.table.take() {
            Some(table) => table.finish().map(|_| ()),
            None => Ok(()),
        }
    }
}

/// Writes aligned rows as MF4.
pub struct Mf4AlignedTable {
    /// `None` once finished.
    writer: Option<Mf4SignalWriter<CompleteOnlyFile>>,
    grid: GridSpec,
    name: String,
}

impl Mf4AlignedTable {
    pub fn new(
        file: CompleteOnlyFile,
        name: String,
        comments: &[String],
        columns: &[Column],
        grid: GridSpec,
    ) -> Result<Self, AcqError> {
        let group = SignalGroup {
            name: "aligned".into(),
            channels: columns
                .iter()
                .map(|c| SignalChannel {
                    name: c.name.clone(),
                    unit: c.unit.clone(),
                })
                .collect(),
        };
        let writer = Mf4SignalWriter::new(file, vec![group], Some(comments.join("\n")))
            .map_err(|e| AcqError::io(format!("writing {name}"), e))?;
        Ok(Mf4AlignedTable {
            writer: Some(writer),
            grid,
            name,
        })
    }
}

impl RowSink for Mf4AlignedTable {
    type Error = AcqError;

    fn row(&mut self, row: u64, values: &[Option<f64>]) -> Result<(), AcqError> {
        let Some(writer) = self.writer.as_mut() else {
            return Ok(());
        };
        writer
            .write(0, self.grid.time_ns(row), values)
            .map_err(|e| AcqError::io(format!("writing {}", self.name), e))
    }

    fn finish(&mut self) -> Result<(), AcqError> {
        match self.writer.take() {
            Some(writer) => writer
                .finish()
                .map_err(|e| AcqError::io(format!("writing {}", self.name), e))?
                .finish(),
            None => Ok(()),
        }
    }
}
