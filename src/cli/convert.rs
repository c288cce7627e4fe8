//! `acq convert IN -o OUT`: a CAN log from one format to another.

use std::path::{Path, PathBuf};

use acq_can::log::asc_write::AscWriter;
use acq_can::log::candump;
use acq_can::log::mf4_write::Mf4Writer;
use acq_error::{AcqError, Result};
use acq_io::input::{open_log, LogInput};
use acq_io::output::{CompleteOnlyFile, Output};
use clap::Args;

/// `acq convert`: read any log acq reads, write the format OUT's extension names.
#[derive(Args, Debug)]
pub struct ConvertArgs {
    /// The log to convert (candump -L, Vector ASC or BLF, MF4, told apart by content; `-` is stdin).
    #[arg(value_name = "IN")]
    pub input: PathBuf,
    /// Where to write: `.log` (candump -L), `.asc` (Vector ASC, as python-can writes it) or
    /// `.mf4` (ASAM MDF 4 bus logging, as python-can writes it).
    /// Written to OUT.partial and renamed once complete.
    #[arg(short = 'o', long = "output", value_name = "OUT")]
    pub output: PathBuf,
}

/// The formats acq writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Written {
    Candump,
    Asc,
    Mf4,
}

fn written_format(path: &Path) -> Result<Written> {
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    match extension.as_deref() {
        Some("log") => Ok(Written::Candump),
        Some("asc") => Ok(Written::Asc),
        Some("mf4") => Ok(Written::Mf4),
        _ => Err(AcqError::Config(format!(
            "{}: the format comes from the extension: .log (candump -L), .asc (Vector ASC) or .mf4 (ASAM MDF 4 bus logging)",
            path.display()
        ))),
    }
}

pub fn run_convert(args: ConvertArgs) -> Result<()> {
    let format = written_format(&args.output)?;
    let mut input = open_log(&args.input)?;
    let frames = match format {
        Written::Candump | Written::Asc => convert_to_text(&mut input, &args.output, format)?,
        Written::Mf4 => convert_to_mf4(&mut input, &args.output)?,
    };
    report(frames, &input, &args.output);
    Ok(())
}

/// A frame the output format cannot hold is malformed input (exit 3),
/// anything else an I/O failure.
fn write_error(input: &LogInput, output: &Path, frame: u64, error: std::io::Error) -> AcqError {
    if error.kind() == std::io::ErrorKind::InvalidData {
        AcqError::Malformed(format!("{}: frame {frame}: {error}", input.name))
    } else {
        AcqError::io(format!("writing {}", output.display()), error)
    }
}

fn convert_to_text(input: &mut LogInput, path: &Path, format: Written) -> Result<u64> {
    let mut output = Output::create_complete_only(path)?;
    let mut frames: u64 = 0;
    let mut asc = (format == Written::Asc).then(|| AscWriter::new(Vec::with_capacity(1 << 16)));
    while let Some(frame) = input.next_frame()? {
        frames += 1;
        match &mut asc {
            Some(writer) => {
                writer
                    .write_frame(&frame)
                    .map_err(|e| write_error(input, path, frames, e))?;
                output.buffer.append(writer.get_mut());
            }
            None => candump::push_line(&mut output.buffer, &frame)
                .map_err(|e| AcqError::Malformed(format!("{}: frame {frames}: {e}", input.name)))?,
        }
        output.maybe_flush()?;
    }
    if frames == 0 {
        return Err(acq_io::input::no_frame_read(&input.name, 0));
    }
    if let Some(writer) = asc {
        let rest = writer
            .finish()
            .map_err(|e| write_error(input, path, frames, e))?;
        output.buffer.extend_from_slice(&rest);
    }
    output.finish()?;
    Ok(frames)
}

/// MF4 patches its block lengths at the end, so it is written to a file
/// (`OUT.partial`, renamed once complete), never to stdout.
fn convert_to_mf4(input: &mut LogInput, path: &Path) -> Result<u64> {
    let mut file = CompleteOnlyFile::create(path, "an MF4 log")?;
    let mut writer = Mf4Writer::new(file.file());
    let mut frames: u64 = 0;
    while let Some(frame) = input.next_frame()? {
        frames += 1;
        writer
            .write_frame(&frame)
            .map_err(|e| write_error(input, path, frames, e))?;
    }
    if frames == 0 {
        return Err(acq_io::input::no_frame_read(&input.name, 0));
    }
    writer
        .finish()
        .map_err(|e| write_error(input, path, frames, e))?;
    file.finish()?;
    Ok(frames)
}

fn report(frames: u64, input: &LogInput, output: &Path) {
    eprintln!(
        "acq convert: {frames} frames from {} to {}",
        input.name,
        output.display()
    );
}
