//! `acq convert IN -o OUT`: a CAN log from one format to another.

use std::path::{Path, PathBuf};

use acq_drivers::log::asc_write::AscWriter;
use acq_drivers::log::candump;
use acq_io::error::{AcqError, Result};
use acq_io::input::open_log;
use acq_io::output::Output;
use clap::Args;

/// `acq convert`: read any log acq reads, write the format OUT's extension names.
#[derive(Args, Debug)]
pub struct ConvertArgs {
    /// The log to convert (candump -L or Vector ASC, told apart by content; `-` is stdin).
    #[arg(value_name = "IN")]
    pub input: PathBuf,
    /// Where to write: `.log` (candump -L) or `.asc` (Vector ASC, as python-can writes it).
    /// Written to OUT.partial and renamed once complete.
    #[arg(short = 'o', long = "output", value_name = "OUT")]
    pub output: PathBuf,
}

/// The formats acq writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Written {
    Candump,
    Asc,
}

fn written_format(path: &Path) -> Result<Written> {
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    match extension.as_deref() {
        Some("log") => Ok(Written::Candump),
        Some("asc") => Ok(Written::Asc),
        Some("mf4") => Err(AcqError::Config(format!(
            "{}: acq does not write MF4 yet; write .log or .asc",
            path.display()
        ))),
        _ => Err(AcqError::Config(format!(
            "{}: the format comes from the extension: .log (candump -L) or .asc (Vector ASC)",
            path.display()
        ))),
    }
}

pub fn run_convert(args: ConvertArgs) -> Result<()> {
    let format = written_format(&args.output)?;
    let mut input = open_log(&args.input)?;
    let mut output = Output::create_complete_only(&args.output)?;
    let mut frames: u64 = 0;
    match format {
        Written::Candump => {
            while let Some(frame) = input.next_frame()? {
                candump::push_line(&mut output.buffer, &frame).map_err(|e| {
                    AcqError::Malformed(format!("{}: frame {}: {e}", input.name, frames + 1))
                })?;
                output.maybe_flush()?;
                frames += 1;
            }
        }
        Written::Asc => {
            let mut writer = AscWriter::new(Vec::with_capacity(1 << 16));
            while let Some(frame) = input.next_frame()? {
                writer.write_frame(&frame).map_err(|e| {
                    AcqError::Malformed(format!("{}: frame {}: {e}", input.name, frames + 1))
                })?;
                output.buffer.append(writer.get_mut());
                output.maybe_flush()?;
                frames += 1;
            }
            let rest = writer
                .finish()
                .map_err(|e| AcqError::io(format!("writing {}", args.output.display()), e))?;
            output.buffer.extend_from_slice(&rest);
        }
    }
    output.finish()?;
    eprintln!(
        "acq convert: {frames} frames from {} to {}",
        input.name,
        args.output.display()
    );
    Ok(())
}
