//! MF4 bus logging: acq's writer and reader round-trip every frame MF4
//! carries; python-can (through asammdf, in a scratch virtualenv the test
//! makes: never a dependency of acq; without it the test fails) reads acq's
//! MF4 as the frames written, and acq reads python-can's MF4, stored,
//! deflated and transposed, as the frames python-can was given.

use crate::common;

use std::io::Cursor;
use std::path::{Path, PathBuf};
use std::process::Command;

use acq_can::frame::fd_flags;
use acq_can::log::mf4::{Mf4Reader, ERROR_FRAME_CLASS};
use acq_can::log::mf4_write::Mf4Writer;
use acq_can::log::Place;
use acq_can::{
    CanId, Direction, Frame, FrameBatch, FrameKind, IfaceName, LogFormat, LogReader, ReadError,
};
use proptest::prelude::*;
use serde_json::{json, Value};

fn write(frames: &[Frame]) -> Vec<u8> {
    let mut writer = Mf4Writer::new(Cursor::new(Vec::new()));
    for frame in frames {
        writer.write_frame(frame).unwrap();
    }
    writer.finish().unwrap().into_inner()
}

/// Every frame of an MF4 file, through format detection; any error fails.
fn read(bytes: &[u8]) -> Vec<Frame> {
    let (mut reader, format) = LogReader::detect(bytes).unwrap();
    assert_eq!(format, LogFormat::Mf4);
    let mut frames = Vec::new();
    loop {
        match reader.next_record() {
            Ok(Some(record)) => {
                let ns = record.frame.timestamp_ns;
                assert_eq!(
                    record.timestamp_text,
                    format!("{}.{:09}", ns / 1_000_000_000, ns % 1_000_000_000).as_bytes()
                );
                frames.push(record.frame);
            }
            Ok(None) => break,
            Err(error) => panic!("{error:?}"),
        }
    }
    // Column by column, in batches that end anywhere, the same frames.
    for max in [7, 1 << 16] {
        assert_eq!(read_batched(bytes, max).0, frames, "batches of {max}");
    }
    frames
}

/// Every frame of a log read column by column, `max` a batch, and the
/// reader's notes; any error fails.
fn read_batched<R: std::io::BufRead>(input: R, max: usize) -> (Vec<Frame>, Vec<String>) {
    let (mut reader, _) = LogReader::detect(input).unwrap();
    let mut batch = FrameBatch::default();
    let mut frames = Vec::new();
    loop {
        batch.clear();
        let more = reader.next_batch(&mut batch, max).unwrap();
        assert!(batch.len() <= max);
        frames.extend((0..batch.len()).map(|index| batch.frame(index)));
        if !more {
            return (frames, reader.take_notes());
        }
    }
}

/// What MF4 keeps of a frame: no direction reads Rx; error frames lose
/// their class and details; FD payloads are padded to a DLC step.
fn as_kept(frame: &Frame) -> Frame {
    let mut kept = match frame.kind {
        FrameKind::Error { .. } => {
            Frame::error(frame.timestamp_ns, frame.iface, ERROR_FRAME_CLASS, &[]).unwrap()
        }
        FrameKind::Fd { flags } => {
            let steps = [0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64];
            let len = *steps.iter().find(|&&s| s >= frame.payload().len()).unwrap();
            let mut payload = frame.payload().to_vec();
            payload.resize(len, 0);
            let flags = fd_flags(flags & 1 != 0, flags & 2 != 0);
            Frame::fd(frame.timestamp_ns, frame.iface, frame.id, flags, &payload).unwrap()
        }
        _ => *frame,
    };
    kept.direction = Some(frame.direction.unwrap_or(Direction::Received));
    kept
}

fn frame(start_ns: i64) -> impl Strategy<Value = Frame> {
    let iface = prop::sample::select(&["can0", "can1", "can9", "can255"][..])
        .prop_map(|name| IfaceName::new(name).unwrap());
    // Up to 20 days after the first frame: ns survive f64 seconds.
    let time = (0..20 * 86_400_000_000_000i64).prop_map(move |ns| start_ns + ns);
    common::any_frame(time, iface)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// Frames in time order come back exactly as MF4 keeps them.
    #[test]
    fn writer_then_reader_gives_the_frames(
        start_ns in 0..4_000_000_000_000_000_000i64,
        frames in prop::collection::vec(frame(0), 0..200),
    ) {
        let mut frames: Vec<Frame> = frames
            .into_iter()
            .map(|mut f| { f.timestamp_ns += start_ns; f })
            .collect();
        frames.sort_by_key(|f| f.timestamp_ns);
        let bytes = write(&frames);
        let read = if frames.is_empty() {
            let mut reader = Mf4Reader::new(&bytes[..]);
            assert!(matches!(reader.next_record(), Ok(None)));
            Vec::new()
        } else {
            read(&bytes)
        };
        let kept: Vec<Frame> = frames.iter().map(as_kept).collect();
        prop_assert_eq!(read, kept);
    }

    /// Any cut or byte flip of a valid file is read without a panic and
    /// without looping.
    #[test]
    fn damaged_files_end_in_errors_not_panics(
        frames in prop::collection::vec(frame(1_700_000_000_000_000_000), 1..40),
        cut in any::<prop::sample::Index>(),
        flips in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 0..8),
    ) {
        let mut bytes = write(&frames);
        for (at, byte) in flips {
            let at = at.index(bytes.len());
            bytes[at] ^= byte;
        }
        bytes.truncate(cut.index(bytes.len() + 1));
        let mut reader = Mf4Reader::new(&bytes[..]);
        let ended = (0..bytes.len() + 2)
            .any(|_| matches!(reader.next_record(), Ok(None) | Err(ReadError::Io(_))));
        prop_assert!(ended, "no end after {} records", bytes.len() + 2);
        // Column by column, the frames one by one gives before its first
        // error, and an error where it has one.
        let mut one_by_one = Vec::new();
        let mut reader = Mf4Reader::new(&bytes[..]);
        let failed = loop {
            match reader.next_record() {
                Ok(Some(record)) => one_by_one.push(record.frame),
                Ok(None) => break false,
                Err(_) => break true,
            }
        };
        let (mut batched, mut batch) = (Vec::new(), FrameBatch::default());
        let mut reader = Mf4Reader::new(&bytes[..]);
        let batch_failed = loop {
            batch.clear();
            let more = reader.next_batch(&mut batch, 7);
            batched.extend((0..batch.len()).map(|index| batch.frame(index)));
            match more {
                Ok(true) => {}
                Ok(false) => break false,
                Err(_) => break true,
            }
        };
        prop_assert_eq!(batched, one_by_one);
        prop_assert_eq!(batch_failed, failed);
    }
}

/// How one piece of a file's records is stored when it is split into
/// blocks: as is, deflated, or transposed over `columns` and deflated.
#[derive(Clone, Copy, Debug)]
enum Storage {
    Dt,
    Deflated,
    Transposed { columns: u32 },
}

fn storage() -> impl Strategy<Value = Storage> {
    prop_oneof![
        Just(Storage::Dt),
        Just(Storage::Deflated),
        (1u32..100).prop_map(|columns| Storage::Transposed { columns }),
    ]
}

/// acq's MF4 with its one `##DT` block's records moved into a `##DL` list
/// of blocks appended at the end, cut at `cuts` (byte offsets into the
/// records, wherever they fall: records span blocks, as loggers write
/// them), each stored as its `Storage` says.
fn split_into_blocks(bytes: &[u8], cuts: &[usize], storages: &[Storage]) -> Vec<u8> {
    let u64_at = |at: usize| u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap());
    let dg = u64_at(64 + 24) as usize;
    let data_link = dg + 24 + 2 * 8;
    let dt = u64_at(data_link) as usize;
    assert_eq!(&bytes[dt..dt + 4], b"##DT");
    let records = &bytes[dt + 24..dt + u64_at(dt + 8) as usize];
    let mut cuts: Vec<usize> = cuts.iter().map(|&c| c % (records.len() + 1)).collect();
    cuts.extend([0, records.len()]);
    cuts.sort_unstable();
    cuts.dedup();
    let mut out = bytes.to_vec();
    let block = |out: &mut Vec<u8>, id: &[u8; 4], links: &[u64], data: &[u8]| {
        while out.len() % 8 != 0 {
            out.push(0);
        }
        let at = out.len() as u64;
        out.extend_from_slice(id);
        out.extend_from_slice(&[0; 4]);
        out.extend_from_slice(&((24 + 8 * links.len() + data.len()) as u64).to_le_bytes());
        out.extend_from_slice(&(links.len() as u64).to_le_bytes());
        for link in links {
            out.extend_from_slice(&link.to_le_bytes());
        }
        out.extend_from_slice(data);
        at
    };
    let mut blocks = Vec::new();
    let mut offsets = Vec::new();
    for (index, piece) in cuts.windows(2).enumerate() {
        let piece_bytes = &records[piece[0]..piece[1]];
        offsets.push(piece[0] as u64);
        let zip = |data: &[u8]| {
            use std::io::Write;
            let mut encoder =
                flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
            encoder.write_all(data).unwrap();
            encoder.finish().unwrap()
        };
        let dz = |zip_type: u8, columns: u32, zipped: Vec<u8>| {
            let mut data = b"DT".to_vec();
            data.extend_from_slice(&[zip_type, 0]);
            data.extend_from_slice(&columns.to_le_bytes());
            data.extend_from_slice(&(piece_bytes.len() as u64).to_le_bytes());
            data.extend_from_slice(&(zipped.len() as u64).to_le_bytes());
            data.extend_from_slice(&zipped);
            data
        };
        let at = match storages[index % storages.len()] {
            Storage::Dt => block(&mut out, b"##DT", &[], piece_bytes),
            Storage::Deflated => block(&mut out, b"##DZ", &[], &dz(0, 0, zip(piece_bytes))),
            Storage::Transposed { columns } => {
                // Byte c of every `columns`-byte line, then byte c + 1, ...;
                // what does not fill a line stays as is.
                let columns_usize = columns as usize;
                let lines = piece_bytes.len() / columns_usize;
                let mut transposed = Vec::with_capacity(piece_bytes.len());
                for column in 0..columns_usize {
                    for line in 0..lines {
                        transposed.push(piece_bytes[line * columns_usize + column]);
                    }
                }
                transposed.extend_from_slice(&piece_bytes[lines * columns_usize..]);
                block(&mut out, b"##DZ", &[], &dz(1, columns, zip(&transposed)))
            }
        };
        blocks.push(at);
    }
    let mut links = vec![0u64];
    links.extend(&blocks);
    let mut data = vec![0u8; 4];
    data.extend_from_slice(&(blocks.len() as u32).to_le_bytes());
    for offset in offsets {
        data.extend_from_slice(&offset.to_le_bytes());
    }
    let dl = block(&mut out, b"##DL", &links, &data);
    out[data_link..data_link + 8].copy_from_slice(&dl.to_le_bytes());
    out
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(100))]

    /// Records cut into blocks anywhere, each block stored, deflated or
    /// transposed and deflated, read as the frames written (the reader
    /// inflates the next block on a second thread while it parses one).
    #[test]
    fn records_split_over_stored_and_zipped_blocks_read_as_written(
        frames in prop::collection::vec(frame(1_700_000_000_000_000_000), 1..300),
        cuts in prop::collection::vec(any::<usize>(), 0..12),
        storages in prop::collection::vec(storage(), 1..6),
    ) {
        let mut frames = frames;
        frames.sort_by_key(|f| f.timestamp_ns);
        let bytes = split_into_blocks(&write(&frames), &cuts, &storages);
        let kept: Vec<Frame> = frames.iter().map(as_kept).collect();
        prop_assert_eq!(read(&bytes), kept);
    }
}

#[test]
fn memory_stays_bounded_by_the_input_when_links_point_far() {
    // A header whose first data group is claimed at 1 TiB: the reader reads
    // what there is and reports the block missing, without allocating.
    let mut bytes = write(&[]);
    bytes[64 + 24..64 + 32].copy_from_slice(&(1u64 << 40).to_le_bytes());
    let mut reader = Mf4Reader::new(&bytes[..]);
    match reader.next_record() {
        Err(ReadError::Parse(error)) => assert_eq!(error.at, Place::ByteOffset(1 << 40)),
        other => panic!("{other:?}"),
    }
}

#[test]
fn memory_stays_bounded_when_a_group_claims_huge_records() {
    // Every channel group of a zipped file claims records of 3.75 GiB (found
    // by fuzzing: the room kept for a record that spans two blocks was once
    // sized by this field). Reading ends in errors, and the process never
    // comes near that size. nextest runs each test in its own process, so
    // the peak is this test's.
    let frames: Vec<Frame> = known_frames();
    let mut bytes = split_into_blocks(&write(&frames), &[100, 333], &[Storage::Deflated]);
    let u64_at =
        |bytes: &[u8], at: usize| u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap());
    let dg = u64_at(&bytes, 64 + 24) as usize;
    let mut cg = u64_at(&bytes, dg + 24 + 8) as usize;
    let mut groups = 0;
    while cg != 0 {
        let links = u64_at(&bytes, cg + 16) as usize;
        let data = cg + 24 + 8 * links;
        bytes[data + 24..data + 28].copy_from_slice(&0xF000_0000u32.to_le_bytes());
        cg = u64_at(&bytes, cg + 24) as usize;
        groups += 1;
    }
    assert!(groups > 0);
    let mut reader = Mf4Reader::new(&bytes[..]);
    let ended = (0..100).any(|_| matches!(reader.next_record(), Ok(None) | Err(ReadError::Io(_))));
    assert!(ended);
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    let peak_kb: u64 = status
        .lines()
        .find_map(|line| line.strip_prefix("VmHWM:"))
        .and_then(|value| value.trim().trim_end_matches("kB").trim().parse().ok())
        .unwrap();
    assert!(peak_kb < 512 * 1024, "peak resident memory {peak_kb} kB");
}

/// The known frames: every kind MF4 carries, two channels, whole us.
fn known_frames() -> Vec<Frame> {
    let t = |us: i64| 1_763_719_200_000_000_000 + us * 1000;
    let iface = |name| IfaceName::new(name).unwrap();
    let (can0, can1) = (iface("can0"), iface("can1"));
    let std = |id| CanId::Standard(id);
    let ext = |id| CanId::Extended(id);
    let tx = |mut f: Frame| {
        f.direction = Some(Direction::Transmitted);
        f
    };
    let mut frames = vec![
        Frame::data(t(100), can0, std(0x123), &[0x11, 0x22, 0x33, 0x44]).unwrap(),
        tx(Frame::data(t(250), can1, ext(0x1ABC_DEF0), &[1, 2, 3, 4, 5, 6, 7, 8]).unwrap()),
        Frame::data(t(1000), can0, std(0x7FF), &[]).unwrap(),
        Frame::remote(t(2000), can0, std(0x0C0), 0).unwrap(),
        tx(Frame::remote(t(2500), can1, ext(0x18FE_F100), 5).unwrap()),
        Frame::fd(
            t(3000),
            can0,
            std(0x321),
            fd_flags(true, false),
            &[0x5A; 12],
        )
        .unwrap(),
        Frame::fd(
            t(3500),
            can1,
            ext(0x1F33_4455),
            fd_flags(true, true),
            &[0xC3; 64],
        )
        .unwrap(),
        Frame::fd(t(3700), can1, std(0x42), fd_flags(false, false), &[7; 8]).unwrap(),
        Frame::error(t(4000), can0, ERROR_FRAME_CLASS, &[]).unwrap(),
        Frame::data(t(5000), can1, std(0x010), &[0xDE, 0xAD, 0xBE, 0xEF]).unwrap(),
    ];
    for frame in &mut frames {
        frame.direction.get_or_insert(Direction::Received);
    }
    frames
}

/// python-can's JSON view of a frame (`tests/mf4/frames.py`).
fn as_json(frame: &Frame) -> Value {
    let error = frame.is_error();
    let (fd, brs, esi) = match frame.kind {
        FrameKind::Fd { flags } => (true, flags & 1 != 0, flags & 2 != 0),
        _ => (false, false, false),
    };
    let dlc = match frame.kind {
        FrameKind::Remote { requested_len, .. } => usize::from(requested_len),
        FrameKind::Error { .. } => 0,
        _ => frame.payload().len(),
    };
    let hex: String = frame.payload().iter().map(|b| format!("{b:02x}")).collect();
    json!({
        "timestamp_us": frame.timestamp_ns / 1000,
        "channel": frame.iface.as_str()[3..].parse::<u64>().unwrap(),
        "id": if error { 0 } else { frame.id.raw() },
        "extended": !error && frame.id.is_extended(),
        "remote": matches!(frame.kind, FrameKind::Remote { .. }),
        "error": error,
        "fd": fd,
        "brs": brs,
        "esi": esi,
        "dlc": dlc,
        "data": if error { String::new() } else { hex },
        "rx": frame.direction != Some(Direction::Transmitted),
    })
}

/// The peers' scratch virtualenv with python-can and asammdf
/// (scripts/python-peers can-logs).
fn python() -> PathBuf {
    common::peer_python("can-logs")
}

fn helper(python: &Path, args: &[&str]) -> String {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/mf4/frames.py");
    let output = Command::new(python)
        .arg(script)
        .args(args)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "frames.py {args:?}: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8(output.stdout).unwrap()
}

#[test]
fn python_can_reads_acq_mf4_as_the_frames_written() {
    let python = python();
    let dir = tempfile::tempdir().unwrap();
    let frames = known_frames();
    let path = dir.path().join("acq.mf4");
    std::fs::write(&path, write(&frames)).unwrap();
    let read: Vec<Value> = helper(&python, &["read", path.to_str().unwrap()])
        .lines()
        .map(|line| serde_json::from_str(line).unwrap())
        .collect();
    let expected: Vec<Value> = frames.iter().map(as_json).collect();
    assert_eq!(read.len(), expected.len());
    for (got, want) in read.iter().zip(&expected) {
        assert_eq!(got, want, "python-can on acq's MF4");
    }
}

#[test]
fn acq_reads_python_can_mf4_as_the_frames_given() {
    let python = python();
    let dir = tempfile::tempdir().unwrap();
    let frames = known_frames();
    let jsonl = dir.path().join("frames.jsonl");
    let lines: Vec<String> = frames.iter().map(|f| as_json(f).to_string()).collect();
    std::fs::write(&jsonl, lines.join("\n")).unwrap();
    for level in ["0", "1", "2"] {
        let path = dir.path().join(format!("python-can-{level}.mf4"));
        helper(
            &python,
            &[
                "write",
                jsonl.to_str().unwrap(),
                path.to_str().unwrap(),
                level,
            ],
        );
        let read = read(&std::fs::read(&path).unwrap());
        assert_eq!(read.len(), frames.len(), "compression {level}");
        for (got, want) in read.iter().zip(&frames) {
            // python-can stores t as f64 seconds from a start of float
            // epoch seconds: its last bits are worth about 0.24 us.
            let off_ns = got.timestamp_ns - want.timestamp_ns;
            assert!(
                off_ns.abs() < 1000,
                "compression {level}: {got:?} is {off_ns} ns off"
            );
            let mut got = *got;
            got.timestamp_ns = want.timestamp_ns;
            assert_eq!(&got, want, "compression {level}");
        }
    }
}

/// Files shaped as data loggers write them (tests/mf4/loggers.py: virtual
/// and constant members, DataLength through a table, float and integer
/// masters with a conversion, `##DZ` of both zip types, VLSD DataBytes in
/// `##SD`, `##DZ`, a `##DL` of `##SD` and a VLSD channel group before or
/// after its record, CAN FD, unfinalized files with a cut record, a list
/// never updated and a last block's length never written): acq reads each
/// frame for frame as asammdf reads it and as the frames were written.
#[test]
fn acq_reads_files_shaped_as_loggers_write_them_as_asammdf_does() {
    const START_NS: i64 = 1_700_000_000_000_000_000;
    let python = python();
    let dir = tempfile::tempdir().unwrap();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/mf4/loggers.py");
    let output = Command::new(&python)
        .arg(&script)
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    // Absolute microseconds are rounded differently by the two sides:
    // compare the nanoseconds from the start.
    let frames = |text: &str| -> Vec<Value> {
        text.lines()
            .map(|line| {
                let mut frame: Value = serde_json::from_str(line).unwrap();
                frame.as_object_mut().unwrap().remove("timestamp_us");
                frame
            })
            .collect()
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|entry| entry.unwrap().path())
        .filter(|path| path.extension().is_some_and(|e| e == "mf4"))
        .collect();
    files.sort();
    assert!(files.len() >= 13, "{files:?}");
    for path in &files {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let expected_path = dir.path().join(format!("{name}.expected.jsonl"));
        let written = frames(&std::fs::read_to_string(expected_path).unwrap());
        let asammdf = frames(&helper(&python, &["read-asammdf", path.to_str().unwrap()]));
        assert_eq!(
            asammdf, written,
            "{name}: asammdf, the reference, disagrees with the writer"
        );
        let (mut reader, format) = LogReader::detect(
            std::fs::File::open(path)
                .map(std::io::BufReader::new)
                .unwrap(),
        )
        .unwrap();
        assert_eq!(format, LogFormat::Mf4, "{name}");
        let mut read = Vec::new();
        let mut one_by_one = Vec::new();
        loop {
            match reader.next_record() {
                Ok(Some(record)) => {
                    one_by_one.push(record.frame);
                    let mut frame = as_json(&record.frame);
                    let object = frame.as_object_mut().unwrap();
                    object.remove("timestamp_us");
                    object.insert(
                        "timestamp_ns".into(),
                        json!(record.frame.timestamp_ns - START_NS),
                    );
                    read.push(frame);
                }
                Ok(None) => break,
                Err(error) => panic!("{name}: {error:?}"),
            }
        }
        let notes = reader.take_notes();
        assert_eq!(
            read.len(),
            written.len(),
            "{name}: frames read, notes {notes:?}"
        );
        // Column by column, in batches that end anywhere: the same frames
        // as one by one, and the same notes.
        for max in [7, 1 << 16] {
            let file = std::io::BufReader::new(std::fs::File::open(path).unwrap());
            let (batched, batch_notes) = read_batched(file, max);
            assert_eq!(batched, one_by_one, "{name}: batches of {max}");
            assert_eq!(batch_notes, notes, "{name}: batches of {max}");
        }
        for (got, want) in read.iter().zip(&written) {
            assert_eq!(got, want, "{name}");
        }
        let cut = notes
            .iter()
            .any(|note| note.contains("cut off inside a record"));
        assert_eq!(cut, name == "unfinalized_cut.mf4", "{name}: {notes:?}");
    }
}
