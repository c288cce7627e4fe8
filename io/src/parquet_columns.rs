//! A Parquet file written a column at a time, where a text column that
//! holds one value in every row (a lake file's unit, session and source)
//! is encoded once per row group instead of once per row.
//!
//! The Arrow writer interns every row's text in the column's dictionary
//! and compares it with the chunk's minimum and maximum: for three such
//! columns that was a fifth of an ingest's time, to write the same few
//! bytes in each file. Here the varying columns go through parquet's own
//! column writers as before, and each constant column's chunk is made
//! whole: a dictionary page holding the value, one data page whose
//! indices are a single run of zeros, its statistics and page index. It
//! reads as the Arrow writer's chunk does (the same schema, values,
//! statistics and page index; `tests` reads both back), only uncompressed
//! since it is a few bytes.
//!
//! Hand-made because parquet offers no way to say a column is constant:
//! a dictionary or run-end encoded array is expanded row by row.

use std::sync::Arc;

use arrow_array::RecordBatch;
use arrow_schema::SchemaRef;
use bytes::Bytes;
use parquet::arrow::arrow_writer::{compute_leaves, ArrowColumnWriter, ArrowRowGroupWriterFactory};
use parquet::arrow::ArrowWriter;
use parquet::basic::{BoundaryOrder, Compression, Encoding, PageType, Type as PhysicalType};
use parquet::column::page::{CompressedPage, Page, PageWriter};
use parquet::column::writer::ColumnCloseResult;
use parquet::data_type::ByteArray;
use parquet::errors::Result;
use parquet::file::metadata::{
    ColumnChunkMetaData, ColumnIndexBuilder, OffsetIndexBuilder, PageEncodingStats,
};
use parquet::file::statistics::Statistics;
use parquet::file::writer::{SerializedFileWriter, SerializedPageWriter, TrackedWrite};
use parquet::schema::types::ColumnDescPtr;

/// A file's writer taking record batches, its constant columns' chunks
/// made whole.
pub(crate) struct ColumnWiseWriter {
    file: SerializedFileWriter<Vec<u8>>,
    factory: ArrowRowGroupWriterFactory,
    schema: SchemaRef,
    /// Per column, the text every row holds, or `None` for a column whose
    /// values are written.
    constants: Vec<Option<Arc<str>>>,
    /// The row group in progress' writers (`None` before its first row).
    writers: Option<Vec<ArrowColumnWriter>>,
    rows_in_group: usize,
    rows_per_group: usize,
    row_groups: usize,
}

impl ColumnWiseWriter {
    /// Takes over `writer` before its first batch; `constants` as
    /// [`ColumnWiseWriter::constants`].
    pub(crate) fn new(
        writer: ArrowWriter<Vec<u8>>,
        schema: SchemaRef,
        constants: Vec<Option<Arc<str>>>,
        rows_per_group: usize,
    ) -> Result<Self> {
        let (file, factory) = writer.into_serialized_writer()?;
        Ok(ColumnWiseWriter {
            file,
            factory,
            schema,
            constants,
            writers: None,
            rows_in_group: 0,
            rows_per_group: rows_per_group.max(1),
            row_groups: 0,
        })
    }

    /// Writes `batch` (whose constant columns are not read), closing row
    /// groups as they fill.
    pub(crate) fn write(&mut self, batch: &RecordBatch) -> Result<()> {
        let mut offset = 0;
        while offset < batch.num_rows() {
            let rows = (self.rows_per_group - self.rows_in_group).min(batch.num_rows() - offset);
            let part = batch.slice(offset, rows);
            if self.writers.is_none() {
                self.writers = Some(self.factory.create_column_writers(self.row_groups)?);
            }
            let writers = self.writers.as_mut().expect("made above");
            for (k, field) in self.schema.fields().iter().enumerate() {
                if self.constants[k].is_none() {
                    for leaf in compute_leaves(field, part.column(k))? {
                        writers[k].write(&leaf)?;
                    }
                }
            }
            self.rows_in_group += rows;
            offset += rows;
            if self.rows_in_group == self.rows_per_group {
                self.close_row_group()?;
            }
        }
        Ok(())
    }

    fn close_row_group(&mut self) -> Result<()> {
        let Some(writers) = self.writers.take() else {
            return Ok(());
        };
        let rows = std::mem::take(&mut self.rows_in_group);
        let descriptors = self.file.schema_descr().columns().to_vec();
        let mut group = self.file.next_row_group()?;
        for (k, writer) in writers.into_iter().enumerate() {
            match &self.constants[k] {
                None => writer.close()?.append_to_row_group(&mut group)?,
                Some(text) => {
                    let column = descriptors[k].clone();
                    let (bytes, close) = constant_chunk(column, text.as_bytes(), rows)?;
                    group.append_column(&bytes, close)?;
                }
            }
        }
        group.close()?;
        self.row_groups += 1;
        Ok(())
    }

    /// The encoded bytes not yet taken.
    pub(crate) fn inner_mut(&mut self) -> &mut Vec<u8> {
        self.file.inner_mut()
    }

    /// The last row group and the footer.
    pub(crate) fn finish(&mut self) -> Result<()> {
        self.close_row_group()?;
        self.file.finish().map(|_| ())
    }
}

/// The chunk of a BYTE_ARRAY column holding `value` in each of `rows`
/// rows, as parquet's own writer lays it out: a PLAIN dictionary page of
/// the one value, then an RLE_DICTIONARY data page whose indices, zero
/// bits wide (a dictionary of one), are one run of `rows` zeros.
fn constant_chunk(
    column: ColumnDescPtr,
    value: &[u8],
    rows: usize,
) -> Result<(Bytes, ColumnCloseResult)> {
    let mut sink = TrackedWrite::new(Vec::new());
    let mut pages = SerializedPageWriter::new(&mut sink);

    let mut dictionary = Vec::with_capacity(4 + value.len());
    dictionary.extend_from_slice(&(value.len() as u32).to_le_bytes());
    dictionary.extend_from_slice(value);
    let dictionary_size = dictionary.len();
    let dictionary_page = pages.write_page(CompressedPage::new(
        Page::DictionaryPage {
            buf: Bytes::from(dictionary),
            num_values: 1,
            encoding: Encoding::PLAIN,
            is_sorted: true,
        },
        dictionary_size,
    ))?;

    // The bit width, then an RLE run: its header is the run's length
    // shifted left by one (the low bit 0 says RLE), as a ULEB128 varint;
    // its value takes ceil(0 / 8) = 0 bytes.
    let mut indices = vec![0u8];
    let mut header = (rows as u64) << 1;
    loop {
        let byte = (header & 0x7f) as u8;
        header >>= 7;
        if header == 0 {
            indices.push(byte);
            break;
        }
        indices.push(byte | 0x80);
    }
    let indices_size = indices.len();
    let data_page = pages.write_page(CompressedPage::new(
        Page::DataPage {
            buf: Bytes::from(indices),
            num_values: rows as u32,
            encoding: Encoding::RLE_DICTIONARY,
            def_level_encoding: Encoding::RLE,
            rep_level_encoding: Encoding::RLE,
            statistics: None,
        },
        indices_size,
    ))?;
    pages.close()?;
    let bytes = Bytes::from(sink.into_inner()?);
    let total = bytes.len() as i64;

    let value_bytes = || ByteArray::from(value.to_vec());
    let unencoded = (rows * value.len()) as i64;
    let metadata = ColumnChunkMetaData::builder(column)
        .set_compression(Compression::UNCOMPRESSED)
        .set_encodings(vec![
            Encoding::PLAIN,
            Encoding::RLE,
            Encoding::RLE_DICTIONARY,
        ])
        .set_page_encoding_stats(vec![
            PageEncodingStats {
                page_type: PageType::DICTIONARY_PAGE,
                encoding: Encoding::PLAIN,
                count: 1,
            },
            PageEncodingStats {
                page_type: PageType::DATA_PAGE,
                encoding: Encoding::RLE_DICTIONARY,
                count: 1,
            },
        ])
        .set_num_values(rows as i64)
        .set_total_compressed_size(total)
        .set_total_uncompressed_size(total)
        .set_dictionary_page_offset(Some(dictionary_page.offset as i64))
        .set_data_page_offset(data_page.offset as i64)
        .set_statistics(Statistics::new(
            Some(value_bytes()),
            Some(value_bytes()),
            None,
            Some(0),
            false,
        ))
        .set_unencoded_byte_array_data_bytes(Some(unencoded))
        .build()?;

    let mut column_index = ColumnIndexBuilder::new(PhysicalType::BYTE_ARRAY);
    column_index.append(false, value.to_vec(), value.to_vec(), 0);
    column_index.set_boundary_order(BoundaryOrder::ASCENDING);
    let mut offset_index = OffsetIndexBuilder::new();
    offset_index.append_offset_and_size(data_page.offset as i64, data_page.bytes_written as i32);
    offset_index.append_row_count(rows as i64);
    offset_index.append_unencoded_byte_array_data_bytes(Some(unencoded));

    let close = ColumnCloseResult {
        bytes_written: total as u64,
        rows_written: rows as u64,
        metadata,
        bloom_filter: None,
        column_index: Some(column_index.build()?),
        offset_index: Some(offset_index.build()),
    };
    Ok((bytes, close))
}

#[cfg(test)]
mod tests {
    use crate::output::Output;
    use crate::parquet_table::{ColumnSpec, ColumnType, FileLayout, ParquetTable};
    use arrow_array::RecordBatch;
    use parquet::arrow::arrow_reader::{ArrowReaderOptions, ParquetRecordBatchReaderBuilder};
    use parquet::file::metadata::{PageIndexPolicy, ParquetMetaData};
    use parquet::file::page_index::column_index::ColumnIndexMetaData;

    /// The same rows written with constant columns and with the same text
    /// set row by row: the batches read back, the row groups and every
    /// column chunk's statistics and page index' bounds.
    #[test]
    fn constant_columns_read_back_as_the_arrow_writer_s() {
        let dir = tempfile::tempdir().unwrap();
        let texts = [
            ("unit", "µε"),
            ("session", ""),
            ("source_file", "/logs/a b/ü.mf4"),
        ];
        // Pages of the written columns shorter than the constant columns'
        // one page per row group, as a lake's samples files have them.
        let layout = FileLayout {
            rows_per_group: Some(70_000),
            rows_per_page: Some(4096),
            // A batch that a row group's end cuts.
            rows_per_batch: Some(3000),
            ..FileLayout::FOR_EVERY_ENGINE
        };
        // Two full row groups and a short one; none; one row.
        for rows in [2 * 70_000 + 123, 0, 1] {
            let write = |name: &str, constant: bool| {
                let path = dir.path().join(name);
                let mut columns = vec![
                    ColumnSpec::new("time", ColumnType::Time),
                    ColumnSpec::new("value", ColumnType::Float).nullable(),
                ];
                for (name, text) in texts {
                    columns.push(if constant {
                        ColumnSpec::constant_text(name, text)
                    } else {
                        ColumnSpec::new(name, ColumnType::Text)
                    });
                }
                let output = Output::create_complete_only(&path).unwrap();
                let mut table = ParquetTable::with_layout(output, &columns, &[], layout).unwrap();
                for row in 0..rows {
                    table.time_ns(0, 1_764_547_200_000_000_000 + row as i64 * 1_250_000);
                    table.float(1, (row % 11 != 3).then_some((row as f64 * 0.37).sin()));
                    if !constant {
                        for (k, (_, text)) in texts.iter().enumerate() {
                            table.text(2 + k, Some(text));
                        }
                    }
                    table.end_row().unwrap();
                }
                assert_eq!(table.finish().unwrap(), rows as u64);
                path
            };
            let [by_column, by_row] = [
                write("constant.parquet", true),
                write("rows.parquet", false),
            ];
            let (batches, metadata) = read(&by_column);
            let (expected_batches, expected_metadata) = read(&by_row);
            assert_eq!(batches, expected_batches, "{rows} rows");
            let groups = metadata.row_groups();
            assert_eq!(groups.len(), expected_metadata.row_groups().len());
            for (g, (group, expected)) in groups
                .iter()
                .zip(expected_metadata.row_groups())
                .enumerate()
            {
                assert_eq!(group.num_rows(), expected.num_rows());
                for k in 0..5 {
                    let (chunk, expected_chunk) = (group.column(k), expected.column(k));
                    assert_eq!(chunk.num_values(), expected_chunk.num_values());
                    assert_eq!(
                        chunk.statistics(),
                        expected_chunk.statistics(),
                        "group {g}, column {k}"
                    );
                }
                for k in 2..5 {
                    let bounds = |metadata: &ParquetMetaData| match &metadata
                        .column_index()
                        .unwrap()[g][k]
                    {
                        ColumnIndexMetaData::BYTE_ARRAY(index) => {
                            let pages = index.num_pages() as usize;
                            let first = index.min_value(0).map(<[u8]>::to_vec);
                            let last = index.max_value(pages - 1).map(<[u8]>::to_vec);
                            (first, last, index.null_count(0))
                        }
                        other => panic!("{other:?}"),
                    };
                    assert_eq!(bounds(&metadata), bounds(&expected_metadata));
                    let rows_of = |metadata: &ParquetMetaData| {
                        let pages = &metadata.offset_index().unwrap()[g][k].page_locations;
                        (pages[0].first_row_index, pages.len())
                    };
                    assert_eq!(rows_of(&metadata).0, 0);
                    assert_eq!(rows_of(&metadata).1, 1, "one data page");
                }
            }
        }
    }

    fn read(path: &std::path::Path) -> (Vec<RecordBatch>, std::sync::Arc<ParquetMetaData>) {
        let file = std::fs::File::open(path).unwrap();
        let options = ArrowReaderOptions::new().with_page_index_policy(PageIndexPolicy::Required);
        let builder = ParquetRecordBatchReaderBuilder::try_new_with_options(file, options).unwrap();
        let metadata = builder.metadata().clone();
        let batches = builder.build().unwrap().map(Result::unwrap).collect();
        (batches, metadata)
    }
}
