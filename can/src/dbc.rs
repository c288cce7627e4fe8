//! DBC signal decoding, compiled from the `can-dbc` AST.
//!
//! A [`DbcDatabase`] is built once from one or more DBC files; every signal
//! becomes a [`SignalCodec`] holding a precompiled [`BitField`], so decoding a
//! frame is an id lookup plus a few shifts per signal. Values follow
//! cantools' rules (checked against its golden vectors in `tests/golden/`):
//! identity and integer scaling stay exact integers, anything else is
//! `raw * factor + offset` in `f64`; float32 signals are widened to `f64`.
//!
//! # Conformance with cantools
//!
//! Decoded values equal cantools' (45.1.0, `decode_choices=False`,
//! `scaling=True`) for the same DBC and frame, bit for bit and int vs
//! float alike, multiplexing and extended multiplexing (`SG_MUL_VAL_`,
//! `m<v>M`) included: the same signals, and the same frames refused. Two tests hold that: the golden vectors
//! (`tests/golden/`), and `can/tests/it/opendbc.rs`, which loads every DBC
//! of the opendbc package (0.3.1: 151 files, those it generates included)
//! with cantools and acq and compares random frames of every message. Every
//! DBC cantools loads, acq loads too or refuses for a reason in this table;
//! the test checks that and the counts in the last column (opendbc 0.3.1).
//!
//! | feature | why acq differs | opendbc 0.3.1 |
//! | --- | --- | --- |
//! | A DBC file with no messages | A file without `BO_` lines decodes nothing; refusing it catches the wrong file given as a DBC (cantools loads an empty database). | 8 files, 0 messages (honda generator sources holding only `CM_ "IMPORT ..."` lines) |
//! | Non-ASCII text read as cp1252 | cantools' `load_file` reads DBC text as cp1252; acq reads UTF-8 (Latin-1 when the file is not UTF-8), which is what opendbc and current tools write. Values are the same; a label (or unit, comment) with non-ASCII characters differs: `verfügbar`, not `verfÃ¼gbar`. | 3 files, 33 messages (labels; vw_mlb, and hyundai_canfd which cantools loads only with strict=False) |

use std::sync::Arc;

use can_dbc::{Dbc, MessageId, MultiplexIndicator, SignalExtendedValueType, ValueType};
use rustc_hash::FxHashMap;

use crate::bits::{BitField, ByteOrder};
use crate::frame::CanId;
use crate::id_index::IdIndex;
use crate::j1939::J1939Id;

/// A physical value as cantools would give it: an exact integer when the
/// scaling is integral, a float otherwise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PhysicalValue {
    Integer(i128),
    Float(f64),
}

impl PhysicalValue {
    #[inline]
    pub fn as_f64(self) -> f64 {
        match self {
            // From 64 bits where the value fits (nearly always): the same
            // nearest f64, without the software conversion from 128.
            PhysicalValue::Integer(v) => match i64::try_from(v) {
                Ok(v) => v as f64,
                Err(_) => v as f64,
            },
            PhysicalValue::Float(v) => v,
        }
    }

    /// Appends the value in shortest round-trip form (`42`, `116.88999938964844`,
    /// `1e-7`, `NaN`, `inf`); integral floats drop the `.0`.
    #[inline]
    pub fn push_shortest(self, out: &mut Vec<u8>) {
        match self {
            PhysicalValue::Integer(v) => {
                out.extend_from_slice(itoa::Buffer::new().format(v).as_bytes())
            }
            PhysicalValue::Float(v) => push_shortest_f64(out, v),
        }
    }

    /// The text [`PhysicalValue::push_shortest`] appends, written in
    /// `buffer`, where it is written there whole: every integer, and every
    /// float below 1e15 in magnitude. `None` for the rest (from 1e15 up,
    /// NaN, infinities), whose text is mended as it is appended.
    #[inline(always)]
    pub fn shortest_text(self, buffer: &mut ValueTextBuffer) -> Option<&[u8]> {
        match self {
            PhysicalValue::Integer(v) => Some(buffer.integer.format(v).as_bytes()),
            PhysicalValue::Float(v) if v.abs() < 1e15 => {
                Some(shortest_f64_text(&mut buffer.float, v))
            }
            PhysicalValue::Float(_) => None,
        }
    }
}

/// Room for one value's text ([`PhysicalValue::shortest_text`]).
#[derive(Default)]
pub struct ValueTextBuffer {
    integer: itoa::Buffer,
    float: zmij::Buffer,
}

/// zmij's shortest text of a finite `value` without a trailing `.0`.
#[inline(always)]
fn shortest_f64_text(buffer: &mut zmij::Buffer, value: f64) -> &[u8] {
    let text = buffer.format_finite(value).as_bytes();
    text.strip_suffix(b".0").unwrap_or(text)
}

/// Appends `value` in shortest round-trip form, without a trailing `.0`,
/// and with a positive exponent unsigned (`1e16`: the text acq wrote with
/// ryu before; zmij writes `1e+16`).
#[inline]
pub fn push_shortest_f64(out: &mut Vec<u8>, value: f64) {
    let mut buffer = zmij::Buffer::new();
    let text = if value.is_finite() {
        shortest_f64_text(&mut buffer, value)
    } else {
        // `NaN`, `inf`, `-inf`.
        buffer.format(value).as_bytes()
    };
    // A sign is only a positive exponent's, which zmij writes from 1e16
    // up: a value below 1e15 is not searched for one (a search was about
    // a tenth of a value's text).
    if value.abs() < 1e15 {
        out.extend_from_slice(text);
        return;
    }
    // Within the last four bytes (`e+308`): a loop over those, where
    // memchr's call and dispatch on every value were a twentieth of a
    // CSV decode.
    let exponent = text.len().saturating_sub(4);
    match text[exponent..]
        .iter()
        .position(|&b| b == b'+')
        .map(|plus| exponent + plus)
    {
        Some(plus) => {
            out.extend_from_slice(&text[..plus]);
            out.extend_from_slice(&text[plus + 1..]);
        }
        None => out.extend_from_slice(text),
    }
}

/// How the raw bits are read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    Unsigned,
    Signed,
    Float32,
    Float64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Scaling {
    Identity,
    Integer { factor: i128, offset: i128 },
    Linear { factor: f64, offset: f64 },
}

/// Which frames carry a signal: cantools' multiplexing tree, flattened.
#[derive(Clone, Debug, PartialEq)]
enum Presence {
    /// Every frame (a plain signal, a top-level multiplexor).
    Always,
    /// Frames whose multiplexor `switch` (an index into
    /// [`MessageCodec::switches`]) is read and has a value in `values`
    /// (inclusive ranges).
    Switched {
        switch: usize,
        values: Vec<(i128, i128)>,
    },
    /// No frame: its multiplexor is not a multiplexor signal of the message,
    /// or is never read itself. cantools leaves such signals out too.
    Never,
}

impl Presence {
    /// Whether a frame whose multiplexors read `switches` carries the signal.
    #[inline]
    fn holds(&self, switches: &[Option<i128>]) -> bool {
        match self {
            Presence::Always => true,
            Presence::Never => false,
            Presence::Switched { switch, values } => switches
                .get(*switch)
                .copied()
                .flatten()
                .is_some_and(|value| in_ranges(values, value)),
        }
    }
}

#[inline]
fn in_ranges(ranges: &[(i128, i128)], value: i128) -> bool {
    ranges
        .iter()
        .any(|&(low, high)| low <= value && value <= high)
}

/// A multiplexor signal that frames read.
#[derive(Clone, Debug)]
struct Switch {
    /// Index into [`MessageCodec::signals`].
    signal: usize,
    /// The values that select a page (inclusive ranges): those of its
    /// signals and its value-table keys, as cantools' `_create_codec`.
    /// Empty: it selects nothing and any value decodes.
    pages: Vec<(i128, i128)>,
}

/// How many multiplexor values a frame keeps on the stack; messages with
/// more multiplexors (rare) use the heap.
const INLINE_SWITCHES: usize = 4;

/// One signal, ready to decode.
#[derive(Clone, Debug)]
pub struct SignalCodec {
    pub name: String,
    pub unit: String,
    pub field: BitField,
    pub encoding: Encoding,
    pub factor: f64,
    pub offset: f64,
    scaling: Scaling,
    /// The DBC's multiplexer marker value (`m<v>`, `m<v>M`); `None` for a
    /// signal without one, which is in every frame. Which frames carry a
    /// signal with one is [`SignalCodec::is_multiplexed`]'s business.
    pub multiplexer_value: Option<u64>,
    /// Which frames carry it.
    presence: Presence,
    /// Value-table labels by raw value, sorted.
    labels: Vec<(i64, String)>,
}

impl SignalCodec {
    /// The raw value read from the payload, as a signed integer for
    /// integer signals (label lookups and multiplexing use it).
    #[inline]
    fn raw_integer(&self, raw: u64) -> i128 {
        match self.encoding {
            Encoding::Signed => i128::from(self.field.sign_extend(raw)),
            _ => i128::from(raw),
        }
    }

    /// [`SignalCodec::raw_integer`] as the nearest f64, converted from 64
    /// bits: the same value (both round to nearest), without the software
    /// conversion from 128 bits a linear signal would pay per value.
    #[inline]
    fn raw_float(&self, raw: u64) -> f64 {
        match self.encoding {
            Encoding::Signed => self.field.sign_extend(raw) as f64,
            _ => raw as f64,
        }
    }

    /// Whether some frames lack this signal: it is switched by a
    /// multiplexor (or never decoded at all, as cantools does not).
    pub fn is_multiplexed(&self) -> bool {
        !matches!(self.presence, Presence::Always)
    }

    /// Decodes the signal from a payload; `None` if the payload is too short.
    #[inline]
    pub fn decode(&self, payload: &[u8]) -> Option<PhysicalValue> {
        let raw = self.field.extract(payload)?;
        Some(self.scale(raw))
    }

    #[inline]
    fn scale(&self, raw: u64) -> PhysicalValue {
        let float = match self.encoding {
            Encoding::Float32 => Some(f64::from(f32::from_bits(raw as u32))),
            Encoding::Float64 => Some(f64::from_bits(raw)),
            _ => None,
        };
        match (float, self.scaling) {
            (Some(x), Scaling::Identity) => PhysicalValue::Float(x),
            (Some(x), _) => PhysicalValue::Float(x * self.factor + self.offset),
            (None, Scaling::Identity) => PhysicalValue::Integer(self.raw_integer(raw)),
            (None, Scaling::Integer { factor, offset }) => {
                PhysicalValue::Integer(self.raw_integer(raw) * factor + offset)
            }
            (None, Scaling::Linear { factor, offset }) => {
                PhysicalValue::Float(self.raw_float(raw) * factor + offset)
            }
        }
    }

    /// Writes the physical `value` into the payload: the inverse of
    /// [`SignalCodec::decode`] (rounded to the nearest raw step, saturated
    /// at the field's range). Used by the simulator to put a sensor on the wire.
    pub fn encode(&self, value: f64, payload: &mut [u8]) -> Option<()> {
        let raw = match self.encoding {
            Encoding::Float32 => {
                u64::from((((value - self.offset) / self.factor) as f32).to_bits())
            }
            Encoding::Float64 => ((value - self.offset) / self.factor).to_bits(),
            Encoding::Unsigned | Encoding::Signed => {
                let steps = ((value - self.offset) / self.factor).round();
                let bits = self.field.length_bits();
                let (low, high) = if self.encoding == Encoding::Signed {
                    (
                        -(2f64.powi(bits as i32 - 1)),
                        2f64.powi(bits as i32 - 1) - 1.0,
                    )
                } else {
                    (0.0, 2f64.powi(bits as i32) - 1.0)
                };
                let clamped = if steps.is_nan() {
                    0.0
                } else {
                    steps.clamp(low, high)
                };
                if self.encoding == Encoding::Signed {
                    (clamped as i64) as u64
                } else {
                    clamped as u64
                }
            }
        };
        self.field.insert(payload, raw)
    }

    /// The value-table label of the raw value in `payload`, if any.
    pub fn label(&self, payload: &[u8]) -> Option<&str> {
        if self.labels.is_empty() || matches!(self.encoding, Encoding::Float32 | Encoding::Float64)
        {
            return None;
        }
        let raw = i64::try_from(self.raw_integer(self.field.extract(payload)?)).ok()?;
        self.labels
            .binary_search_by_key(&raw, |(value, _)| *value)
            .ok()
            .map(|i| self.labels[i].1.as_str())
    }

    pub fn labels(&self) -> &[(i64, String)] {
        &self.labels
    }
}

/// One message and its signals.
#[derive(Clone, Debug)]
pub struct MessageCodec {
    pub id: CanId,
    pub name: String,
    /// Payload length declared in the DBC, bytes.
    pub size: usize,
    pub signals: Vec<SignalCodec>,
    /// The multiplexors that frames read, each after the one that switches
    /// it (if any): reading them in this order decides every signal's
    /// presence in one pass.
    switches: Vec<Switch>,
    /// The DBC file this message came from.
    pub source: Arc<str>,
    /// Its parameter group number when the DBC declares it a J1939
    /// message (`ProtocolType "J1939"`, or its `VFrameFormat` is
    /// `J1939PG`): frames of that PGN match it from any source address and
    /// priority, as J1939 tools and asammdf match them.
    pub j1939_pgn: Option<u32>,
}

/// A signal of a message without multiplexors, as
/// [`MessageCodec::unswitched`] gives it: decoded as
/// [`MessageCodec::decode_signal`] decodes it, with the message's length
/// checked and no switches read. A decoder of millions of frames per
/// second calls this per sample, where the general path's closure and
/// switch table cost more than the field's extraction.
#[derive(Clone, Copy, Debug)]
pub struct UnswitchedSignal<'a> {
    signal: &'a SignalCodec,
    message_bytes: usize,
}

impl UnswitchedSignal<'_> {
    /// The signal's value in `payload`; an error for a frame shorter than
    /// the message, `None` where the field lies past a longer message's end.
    #[inline]
    pub fn decode(&self, payload: &[u8]) -> Result<Option<PhysicalValue>, FrameDecodeError> {
        if payload.len() < self.message_bytes {
            return Err(FrameDecodeError::Short {
                got: payload.len(),
                needed: self.message_bytes,
            });
        }
        Ok(self.signal.decode(payload))
    }
}

/// A frame its DBC message cannot decode (cantools refuses the same ones).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FrameDecodeError {
    #[error("frame has {got} bytes, the DBC message needs {needed}")]
    Short { got: usize, needed: usize },
    /// The multiplexor's value as cantools takes it: its scaled value,
    /// truncated to an integer (saturated; a NaN float reads as 0).
    #[error(
        "multiplexer value {0} selects no signals and is not in the multiplexor's value table"
    )]
    UnknownMultiplexerValue(i128),
}

impl MessageCodec {
    /// Calls `emit(signal_index, value)` for every signal present in the
    /// payload: all plain signals, and multiplexed ones only when their
    /// multiplexor (itself present) selects them. A frame shorter than the
    /// message, or with a multiplexor value that is no page (neither
    /// selects a signal nor is in the multiplexor's value table), is
    /// refused whole, as cantools does.
    #[inline]
    pub fn decode(
        &self,
        payload: &[u8],
        mut emit: impl FnMut(usize, PhysicalValue),
    ) -> Result<(), FrameDecodeError> {
        self.check_length(payload)?;
        // Most messages have no multiplexor: their signals decoded where
        // the caller's loop holds them, not in a function of their own.
        if self.switches.is_empty() {
            self.emit_present(payload, &[], &mut emit);
            return Ok(());
        }
        self.with_switches(payload, |switches| {
            self.emit_present(payload, switches, &mut emit)
        })
    }

    /// [`MessageCodec::decode`]'s values of the signals that a frame whose
    /// multiplexors read `switches` carries.
    #[inline(always)]
    fn emit_present(
        &self,
        payload: &[u8],
        switches: &[Option<i128>],
        emit: &mut impl FnMut(usize, PhysicalValue),
    ) {
        for (index, signal) in self.signals.iter().enumerate() {
            if !signal.presence.holds(switches) {
                continue;
            }
            if let Some(raw) = signal.field.extract(payload) {
                emit(index, signal.scale(raw));
            }
        }
    }

    /// Decodes one signal: `Ok(None)` when the multiplexer does not select it.
    #[inline]
    pub fn decode_signal(
        &self,
        payload: &[u8],
        index: usize,
    ) -> Result<Option<PhysicalValue>, FrameDecodeError> {
        self.check_length(payload)?;
        self.with_switches(payload, |switches| {
            self.signals
                .get(index)
                .filter(|signal| signal.presence.holds(switches))
                .and_then(|signal| signal.decode(payload))
        })
    }

    /// Signal `index` as an [`UnswitchedSignal`], if the message has no
    /// multiplexor (so every frame of it carries the signal).
    pub fn unswitched(&self, index: usize) -> Option<UnswitchedSignal<'_>> {
        let signal = self.signals.get(index)?;
        (self.switches.is_empty() && matches!(signal.presence, Presence::Always)).then_some(
            UnswitchedSignal {
                signal,
                message_bytes: self.size,
            },
        )
    }

    /// Refuses a frame shorter than the message.
    #[inline]
    fn check_length(&self, payload: &[u8]) -> Result<(), FrameDecodeError> {
        if payload.len() < self.size {
            return Err(FrameDecodeError::Short {
                got: payload.len(),
                needed: self.size,
            });
        }
        Ok(())
    }

    /// Reads the multiplexors of `payload` (`None` for one the frame does
    /// not carry) and gives them to `then`; an unknown page is an error.
    #[inline]
    fn with_switches<R>(
        &self,
        payload: &[u8],
        then: impl FnOnce(&[Option<i128>]) -> R,
    ) -> Result<R, FrameDecodeError> {
        if self.switches.is_empty() {
            return Ok(then(&[]));
        }
        let mut inline = [None; INLINE_SWITCHES];
        let mut heap = Vec::new();
        let values: &mut [Option<i128>] = if self.switches.len() <= INLINE_SWITCHES {
            &mut inline[..self.switches.len()]
        } else {
            heap.resize(self.switches.len(), None);
            &mut heap
        };
        for (k, switch) in self.switches.iter().enumerate() {
            let signal = &self.signals[switch.signal];
            // Its own multiplexor comes earlier in `switches`.
            if !signal.presence.holds(&values[..k]) {
                continue;
            }
            let Some(raw) = signal.field.extract(payload) else {
                continue;
            };
            // cantools picks the page by `int()` of the scaled value.
            let value = match signal.scale(raw) {
                PhysicalValue::Integer(v) => v,
                PhysicalValue::Float(v) => v as i128,
            };
            if !switch.pages.is_empty() && !in_ranges(&switch.pages, value) {
                return Err(FrameDecodeError::UnknownMultiplexerValue(value));
            }
            values[k] = Some(value);
        }
        Ok(then(values))
    }

    pub fn signal(&self, name: &str) -> Option<(usize, &SignalCodec)> {
        self.signals
            .iter()
            .enumerate()
            .find(|(_, s)| s.name == name)
    }
}

/// A DBC could not be used.
#[derive(Debug, thiserror::Error)]
pub enum DbcError {
    #[error("cannot read DBC file {source_name}: {detail}")]
    Unreadable { source_name: String, detail: String },
    #[error("{source_name}: not a valid DBC file: {detail}")]
    Syntax { source_name: String, detail: String },
    #[error("{source_name}: message {message} (id {id}): signal {signal}: {detail}")]
    Signal {
        source_name: String,
        message: String,
        id: CanId,
        signal: String,
        detail: String,
    },
    #[error("{source_name}: message {message} (id {id}): {detail}")]
    Message {
        source_name: String,
        message: String,
        id: CanId,
        detail: String,
    },
    #[error("{source_name}: no messages (BO_ lines): is this a DBC file?")]
    Empty { source_name: String },
    #[error("{source_name}: message {message}: id 0x{raw:X} is not a valid CAN id")]
    BadId {
        source_name: String,
        message: String,
        raw: u32,
    },
    #[error("message id {id} is defined twice: {first_message} in {first_source} and {second_message} in {second_source}")]
    Duplicate {
        id: CanId,
        first_message: String,
        first_source: String,
        second_message: String,
        second_source: String,
    },
}

/// Something in a DBC that was skipped; loading went on.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DbcWarning(pub String);

/// All messages of one or more DBC files, indexed by CAN id.
#[derive(Clone, Debug, Default)]
pub struct DbcDatabase {
    messages: Vec<MessageCodec>,
    /// Index into `messages` by id.
    by_id: IdIndex,
    /// The J1939 messages by PGN, in the order they were added.
    by_pgn: FxHashMap<u32, Vec<u32>>,
    matching: IdMatching,
}

/// How a frame finds its DBC message.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum IdMatching {
    /// By its id; a 29-bit frame no message has the id of, by its PGN
    /// among the messages the DBC declares J1939 (from any source address
    /// and priority: a DBC's J1939 message names one, often 0xFE), the
    /// message of the frame's own source address first.
    #[default]
    J1939ByPgn,
    /// By its exact id only.
    ExactIds,
}

impl DbcDatabase {
    pub fn new() -> Self {
        DbcDatabase {
            messages: Vec::new(),
            by_id: IdIndex::new(),
            by_pgn: FxHashMap::default(),
            matching: IdMatching::default(),
        }
    }

    /// Parses DBC text; `source_name` names it in errors.
    ///
    /// What cannot be decoded at all is an error: no messages, a message
    /// longer than a CAN FD frame, a signal beyond its message or whose
    /// scaling overflows. What decodes but looks wrong is a warning naming
    /// the message and signal once: overlapping signals, a signal name used
    /// twice in a message, a signal that no frame carries. Multiplexing,
    /// extended multiplexing (`SG_MUL_VAL_`, `m<v>M`) included, follows
    /// cantools exactly (see `build_multiplexing`). Vector's placeholder `VECTOR__INDEPENDENT_SIG_MSG`
    /// (signals of no message, no frame of its own) is skipped silently, as
    /// cantools does.
    pub fn parse(text: &str, source_name: &str) -> Result<(Self, Vec<DbcWarning>), DbcError> {
        let dbc = Dbc::try_from(text).map_err(|e| DbcError::Syntax {
            source_name: source_name.to_string(),
            detail: e.to_string(),
        })?;
        let mut database = DbcDatabase::new();
        let mut warnings = Vec::new();
        let source: Arc<str> = Arc::from(source_name);
        let j1939 = J1939Declared::of(&dbc);
        let mut messages = 0;
        for message in &dbc.messages {
            if message.name == INDEPENDENT_SIGNALS_MESSAGE {
                continue;
            }
            messages += 1;
            let mut codec = compile_message(&dbc, message, &source, &mut warnings)?;
            codec.j1939_pgn = j1939.pgn(message, codec.id);
            database.add(codec)?;
        }
        let mut shared: Vec<(&u32, &Vec<u32>)> = database
            .by_pgn
            .iter()
            .filter(|(_, m)| m.len() > 1)
            .collect();
        shared.sort();
        for (pgn, indices) in shared {
            let names: Vec<&str> = indices
                .iter()
                .map(|&i| database.messages[i as usize].name.as_str())
                .collect();
            warnings.push(DbcWarning(format!(
                "{source_name}: J1939 PGN {pgn} ({pgn:#X}) is declared by {} messages ({}): a frame of another source address decodes as {}",
                names.len(),
                names.join(", "),
                names[0]
            )));
        }
        if messages == 0 {
            return Err(DbcError::Empty {
                source_name: source_name.to_string(),
            });
        }
        Ok((database, warnings))
    }

    /// Reads and parses one DBC file (UTF-8, or Latin-1 as Windows tools
    /// often write it).
    pub fn load(path: &std::path::Path) -> Result<(Self, Vec<DbcWarning>), DbcError> {
        let name = path.display().to_string();
        // A FIFO or a device would block or never end.
        if std::fs::metadata(path).is_ok_and(|m| !m.is_file()) {
            return Err(DbcError::Unreadable {
                source_name: name,
                detail: "not a regular file; give the DBC file's path".into(),
            });
        }
        let bytes = std::fs::read(path).map_err(|e| DbcError::Unreadable {
            source_name: name.clone(),
            detail: e.to_string(),
        })?;
        let text = match String::from_utf8(bytes) {
            Ok(text) => text,
            // Latin-1 maps each byte to the code point of the same value.
            Err(e) => e.into_bytes().iter().map(|&b| char::from(b)).collect(),
        };
        Self::parse(&text, &name)
    }

    /// Loads several files into one database; an id in two files is an error.
    pub fn load_all(paths: &[std::path::PathBuf]) -> Result<(Self, Vec<DbcWarning>), DbcError> {
        let mut database = DbcDatabase::new();
        let mut warnings = Vec::new();
        for path in paths {
            let (one, mut more) = Self::load(path)?;
            database.merge(one)?;
            warnings.append(&mut more);
        }
        Ok((database, warnings))
    }

    /// Adds a message; an id defined twice is an error naming both sources.
    pub fn add(&mut self, codec: MessageCodec) -> Result<(), DbcError> {
        if let Some(existing) = self.exact_index(codec.id).map(|i| &self.messages[i]) {
            return Err(DbcError::Duplicate {
                id: codec.id,
                first_message: existing.name.clone(),
                first_source: existing.source.to_string(),
                second_message: codec.name,
                second_source: codec.source.to_string(),
            });
        }
        let index = self.messages.len() as u32;
        if let Some(pgn) = codec.j1939_pgn {
            self.by_pgn.entry(pgn).or_default().push(index);
        }
        self.by_id.insert(codec.id, index);
        self.messages.push(codec);
        Ok(())
    }

    /// Merges another database (another DBC file) into this one.
    pub fn merge(&mut self, other: DbcDatabase) -> Result<(), DbcError> {
        other.messages.into_iter().try_for_each(|m| self.add(m))
    }

    /// The message with this id, if any.
    #[inline]
    pub fn message(&self, id: CanId) -> Option<&MessageCodec> {
        self.message_index(id).map(|i| &self.messages[i])
    }

    /// Index of the message a frame of this id decodes as (stable for the
    /// database's life): the message of that id, else, for a 29-bit id, a
    /// J1939 message of its PGN ([`IdMatching`]).
    #[inline]
    pub fn message_index(&self, id: CanId) -> Option<usize> {
        self.exact_index(id).or_else(|| match id {
            CanId::Extended(_) => self.j1939_message_index(id),
            CanId::Standard(_) => None,
        })
    }

    /// Index of the message of exactly this id.
    #[inline]
    fn exact_index(&self, id: CanId) -> Option<usize> {
        self.by_id.get(id).map(|index| index as usize)
    }

    /// The J1939 message a 29-bit id no message has matches by its PGN:
    /// the one declared with the frame's source address, else the first.
    #[cold]
    fn j1939_message_index(&self, id: CanId) -> Option<usize> {
        if self.matching == IdMatching::ExactIds || self.by_pgn.is_empty() {
            return None;
        }
        let frame = J1939Id::from_can_id(id)?;
        let candidates = self.by_pgn.get(&frame.pgn)?;
        let same_source = candidates.iter().find(|&&i| {
            J1939Id::from_can_id(self.messages[i as usize].id)
                .is_some_and(|declared| declared.source_address == frame.source_address)
        });
        same_source.or(candidates.first()).map(|&i| i as usize)
    }

    /// How frames find their message (J1939 by PGN unless asked for exact ids).
    pub fn set_id_matching(&mut self, matching: IdMatching) {
        self.matching = matching;
    }

    /// How many messages are matched by PGN (the DBC declares them J1939).
    pub fn j1939_messages(&self) -> usize {
        self.by_pgn.values().map(Vec::len).sum()
    }

    pub fn messages(&self) -> &[MessageCodec] {
        &self.messages
    }

    pub fn message_by_name(&self, name: &str) -> Option<&MessageCodec> {
        self.messages.iter().find(|m| m.name == name)
    }
}

/// Vector's placeholder message for signals that belong to no message.
const INDEPENDENT_SIGNALS_MESSAGE: &str = "VECTOR__INDEPENDENT_SIG_MSG";

/// The longest payload a CAN frame carries (CAN FD), bytes.
const MAX_PAYLOAD_BYTES: u64 = 64;

/// Compiles one message; what looks wrong in it goes to `warnings`.
fn compile_message(
    dbc: &Dbc,
    message: &can_dbc::Message,
    source: &Arc<str>,
    warnings: &mut Vec<DbcWarning>,
) -> Result<MessageCodec, DbcError> {
    let id = match message.id {
        MessageId::Standard(id) => CanId::standard(id),
        MessageId::Extended(id) => CanId::extended(id),
    }
    .ok_or_else(|| DbcError::BadId {
        source_name: source.to_string(),
        message: message.name.clone(),
        raw: message.id.raw(),
    })?;
    if message.size > MAX_PAYLOAD_BYTES {
        return Err(DbcError::Message {
            source_name: source.to_string(),
            message: message.name.clone(),
            id,
            detail: format!(
                "declared with {} bytes; a CAN frame holds at most {MAX_PAYLOAD_BYTES} (CAN FD)",
                message.size
            ),
        });
    }
    let signal_error = |signal: &str, detail: String| DbcError::Signal {
        source_name: source.to_string(),
        message: message.name.clone(),
        id,
        signal: signal.to_string(),
        detail,
    };

    let mut signals = Vec::with_capacity(message.signals.len());
    for signal in &message.signals {
        let multiplexer_value = match signal.multiplexer_indicator {
            MultiplexIndicator::MultiplexedSignal(v)
            | MultiplexIndicator::MultiplexorAndMultiplexedSignal(v) => Some(v),
            MultiplexIndicator::Plain | MultiplexIndicator::Multiplexor => None,
        };
        let order = match signal.byte_order {
            can_dbc::ByteOrder::LittleEndian => ByteOrder::LittleEndian,
            can_dbc::ByteOrder::BigEndian => ByteOrder::BigEndian,
        };
        let field = BitField::new(order, signal.start_bit, signal.size)
            .map_err(|e| signal_error(&signal.name, e.to_string()))?;
        if field.end_byte() > message.size as usize {
            return Err(signal_error(
                &signal.name,
                format!(
                    "needs {} bytes but the message is declared with {}",
                    field.end_byte(),
                    message.size
                ),
            ));
        }
        let encoding = match dbc.extended_value_type_for_signal(message.id, &signal.name) {
            Some(SignalExtendedValueType::IEEEfloat32Bit) => Encoding::Float32,
            Some(SignalExtendedValueType::IEEEdouble64bit) => Encoding::Float64,
            _ => match signal.value_type {
                ValueType::Signed => Encoding::Signed,
                ValueType::Unsigned => Encoding::Unsigned,
            },
        };
        let needed_bits = match encoding {
            Encoding::Float32 => Some(32),
            Encoding::Float64 => Some(64),
            _ => None,
        };
        if let Some(bits) = needed_bits {
            if signal.size != bits {
                return Err(signal_error(
                    &signal.name,
                    format!(
                        "declared as a {bits}-bit float but {} bits long",
                        signal.size
                    ),
                ));
            }
        }
        check_scaling_range(signal.factor, signal.offset, encoding, signal.size)
            .map_err(|detail| signal_error(&signal.name, detail))?;
        let mut labels: Vec<(i64, String)> = dbc
            .value_descriptions_for_signal(message.id, &signal.name)
            .unwrap_or_default()
            .iter()
            .map(|d| (d.id, d.description.clone()))
            .collect();
        labels.sort_by_key(|(value, _)| *value);
        signals.push(SignalCodec {
            name: signal.name.clone(),
            unit: signal.unit.clone(),
            field,
            encoding,
            factor: signal.factor,
            offset: signal.offset,
            scaling: scaling(signal.factor, signal.offset),
            multiplexer_value,
            presence: Presence::Always,
            labels,
        });
    }
    let switches = build_multiplexing(dbc, message, id, source, &mut signals, warnings);
    warn_about_suspicious_signals(message, id, source, &signals, &switches, warnings);
    Ok(MessageCodec {
        id,
        name: message.name.clone(),
        size: message.size as usize,
        signals,
        switches,
        source: Arc::clone(source),
        j1939_pgn: None,
    })
}

/// Which messages a DBC declares J1939, as CANdb++ and CANalyzer read it:
/// every 29-bit message when the database's `ProtocolType` is `J1939`, or
/// a message whose `VFrameFormat` is `J1939PG` (an index into the
/// attribute's enum, or its text); a `BA_DEF_DEF_` default applies to
/// every object without a value of its own. An 11-bit message is never
/// J1939: it keeps its exact id.
struct J1939Declared<'a> {
    dbc: &'a Dbc,
    whole_database: bool,
    /// `VFrameFormat`'s enum values, when the DBC defines it.
    frame_formats: Option<&'a [String]>,
}

impl<'a> J1939Declared<'a> {
    fn of(dbc: &'a Dbc) -> Self {
        let default = |name: &str| {
            dbc.attribute_defaults
                .iter()
                .find(|d| d.name == name)
                .map(|d| &d.value)
        };
        let protocol = dbc
            .attribute_values_database
            .iter()
            .find(|v| v.name == "ProtocolType")
            .map(|v| &v.value)
            .or_else(|| default("ProtocolType"));
        let whole_database = matches!(protocol, Some(can_dbc::AttributeValue::String(p)) if p.eq_ignore_ascii_case("J1939"));
        let frame_formats = dbc.attribute_definitions.iter().find_map(|d| match d {
            can_dbc::AttributeDefinition::Message(
                name,
                can_dbc::AttributeValueType::Enum(values),
            ) if name == "VFrameFormat" => Some(values.as_slice()),
            _ => None,
        });
        J1939Declared {
            dbc,
            whole_database,
            frame_formats,
        }
    }

    /// The PGN `message` (compiled to `id`) is matched by, if J1939.
    fn pgn(&self, message: &can_dbc::Message, id: CanId) -> Option<u32> {
        let j1939 = J1939Id::from_can_id(id)?;
        let declared = self.whole_database || {
            let value = self
                .dbc
                .attribute_values_message
                .iter()
                .find(|v| v.name == "VFrameFormat" && v.message_id == message.id)
                .map(|v| &v.value)
                .or_else(|| {
                    self.dbc
                        .attribute_defaults
                        .iter()
                        .find(|d| d.name == "VFrameFormat")
                        .map(|d| &d.value)
                });
            let text = match value {
                Some(can_dbc::AttributeValue::String(text)) => Some(text.as_str()),
                Some(can_dbc::AttributeValue::Uint(index)) => self.enum_value(*index),
                Some(can_dbc::AttributeValue::Int(index)) => {
                    u64::try_from(*index).ok().and_then(|i| self.enum_value(i))
                }
                Some(can_dbc::AttributeValue::Double(index))
                    if index.fract() == 0.0 && *index >= 0.0 =>
                {
                    self.enum_value(*index as u64)
                }
                _ => None,
            };
            text == Some("J1939PG")
        };
        declared.then_some(j1939.pgn)
    }

    fn enum_value(&self, index: u64) -> Option<&'a str> {
        let index = usize::try_from(index).ok()?;
        self.frame_formats?.get(index).map(String::as_str)
    }
}

/// Inclusive ranges of multiplexor values.
type Ranges = Vec<(i128, i128)>;

/// One signal's place in cantools' multiplexing tree, before it is resolved.
struct Node {
    /// The multiplexor that switches it, by name.
    parent: Option<String>,
    /// The values of `parent` that select it (inclusive ranges).
    values: Vec<(i128, i128)>,
    is_multiplexor: bool,
}

/// Sets every signal's [`Presence`] and returns the message's switches,
/// following cantools 45.1.0 exactly (`dbc.py` `_load_signals`, `message.py`
/// `_create_codec`):
///
/// - One signal marked `M` or `m<v>M`: plain multiplexing. A signal marked
///   `m<v>` is switched by it at `v` and at the values its `SG_MUL_VAL_`
///   lines for that multiplexor add; lines naming another multiplexor are
///   ignored.
/// - Otherwise (several multiplexors, or none): extended multiplexing.
///   Only `SG_MUL_VAL_` says who switches whom: a marked signal listed
///   there is switched by the line's multiplexor at its ranges (the marker's
///   value is ignored); a marked signal not listed is in every frame.
/// - A signal without a marker is in every frame, listed or not.
/// - A signal switched by a name that is no multiplexor of the message, or
///   by one never read, is in no frame.
/// - A multiplexor's pages are its signals' values and its value-table keys;
///   it selects by `int()` of its scaled value.
fn build_multiplexing(
    dbc: &Dbc,
    message: &can_dbc::Message,
    id: CanId,
    source: &Arc<str>,
    signals: &mut [SignalCodec],
    warnings: &mut Vec<DbcWarning>,
) -> Vec<Switch> {
    let context = MessageContext {
        message,
        id,
        source,
    };
    let lists = MuxValueLists::read(dbc, &context, warnings);
    let nodes = multiplexing_nodes(&context, &lists, warnings);
    let parent_index = parent_indices(&nodes, signals);
    let (order, resolved) = resolution_order(&nodes, &parent_index);
    let switches = assign_presence(&nodes, &parent_index, &order, signals);
    warn_about_never_decoded(&context, &nodes, &resolved, signals, warnings);
    switches
}

/// The message a multiplexing warning speaks of: its name, id and file.
struct MessageContext<'a> {
    message: &'a can_dbc::Message,
    id: CanId,
    source: &'a Arc<str>,
}

/// Whether a signal's marker makes it a multiplexor (`M` or `m<v>M`).
fn is_multiplexor(indicator: &MultiplexIndicator) -> bool {
    matches!(
        indicator,
        MultiplexIndicator::Multiplexor | MultiplexIndicator::MultiplexorAndMultiplexedSignal(_)
    )
}

/// The `SG_MUL_VAL_` lines of one message: multiplexor -> [(signal, values)],
/// in first-seen order; a later line for the same pair replaces the earlier
/// one (cantools keeps them in dicts).
struct MuxValueLists<'a>(Vec<(&'a str, Vec<(&'a str, Ranges)>)>);

impl<'a> MuxValueLists<'a> {
    /// Reads the message's lines, warning of one that names a signal the
    /// message does not have.
    fn read(dbc: &'a Dbc, context: &MessageContext<'_>, warnings: &mut Vec<DbcWarning>) -> Self {
        let MessageContext {
            message,
            id,
            source,
        } = context;
        let mut lists: Vec<(&str, Vec<(&str, Ranges)>)> = Vec::new();
        for list in dbc
            .extended_multiplex
            .iter()
            .filter(|list| list.message_id == message.id)
        {
            if !message.signals.iter().any(|s| s.name == list.signal_name) {
                warnings.push(DbcWarning(format!(
                    "{source}: message {} ({id}): the value list (SG_MUL_VAL_) names signal {}, which the message does not have; ignored",
                    message.name, list.signal_name
                )));
            }
            // A range written high-low selects nothing (cantools: `range(low, high + 1)`).
            let values: Vec<(i128, i128)> = list
                .mappings
                .iter()
                .filter(|m| m.min_value <= m.max_value)
                .map(|m| (i128::from(m.min_value), i128::from(m.max_value)))
                .collect();
            let switch = list.multiplexor_signal_name.as_str();
            let entries = match lists.iter_mut().find(|(name, _)| *name == switch) {
                Some((_, entries)) => entries,
                None => {
                    lists.push((switch, Vec::new()));
                    &mut lists.last_mut().expect("just pushed").1
                }
            };
            match entries
                .iter_mut()
                .find(|(name, _)| *name == list.signal_name)
            {
                Some(entry) => entry.1 = values,
                None => entries.push((list.signal_name.as_str(), values)),
            }
        }
        Self(lists)
    }

    /// The values at which `switch` selects `signal`, if a line lists them.
    fn listed(&self, switch: &str, signal: &str) -> Option<&Ranges> {
        self.0
            .iter()
            .find(|(name, _)| *name == switch)
            .and_then(|(_, entries)| entries.iter().find(|(name, _)| *name == signal))
            .map(|(_, values)| values)
    }

    /// Extended multiplexing: the last multiplexor listing a signal switches it.
    fn switch_of(&self, signal: &str) -> Option<&'a str> {
        self.0
            .iter()
            .rfind(|(_, entries)| entries.iter().any(|(name, _)| *name == signal))
            .map(|(switch, _)| *switch)
    }
}

/// Each signal's unresolved place in the tree, by plain multiplexing when
/// the message has exactly one multiplexor and by extended otherwise.
fn multiplexing_nodes(
    context: &MessageContext<'_>,
    lists: &MuxValueLists<'_>,
    warnings: &mut Vec<DbcWarning>,
) -> Vec<Node> {
    let multiplexors: Vec<&str> = context
        .message
        .signals
        .iter()
        .filter(|s| is_multiplexor(&s.multiplexer_indicator))
        .map(|s| s.name.as_str())
        .collect();
    let plain_multiplexor = match multiplexors[..] {
        [only] => Some(only),
        _ => None,
    };
    context
        .message
        .signals
        .iter()
        .map(|signal| {
            let (parent, values) = match plain_multiplexor {
                Some(switch) => plain_parent_and_values(signal, switch, lists),
                None => {
                    extended_parent_and_values(signal, multiplexors.len(), lists, context, warnings)
                }
            };
            Node {
                parent,
                values,
                is_multiplexor: is_multiplexor(&signal.multiplexer_indicator),
            }
        })
        .collect()
}

/// Plain multiplexing: a marked signal is switched by the one multiplexor at
/// its marker's value and at the values its `SG_MUL_VAL_` line adds.
fn plain_parent_and_values(
    signal: &can_dbc::Signal,
    switch: &str,
    lists: &MuxValueLists<'_>,
) -> (Option<String>, Ranges) {
    let marked = signal.multiplexer_indicator != MultiplexIndicator::Plain;
    let mut values = Vec::new();
    if let MultiplexIndicator::MultiplexedSignal(v) = signal.multiplexer_indicator {
        values.push((i128::from(v), i128::from(v)));
    }
    values.extend(lists.listed(switch, &signal.name).into_iter().flatten());
    let parent = (marked && signal.name != switch).then(|| switch.to_string());
    (parent, values)
}

/// Extended multiplexing: only `SG_MUL_VAL_` says who switches a marked
/// signal; one marked with a value that no line switches is warned of.
fn extended_parent_and_values(
    signal: &can_dbc::Signal,
    multiplexor_count: usize,
    lists: &MuxValueLists<'_>,
    context: &MessageContext<'_>,
    warnings: &mut Vec<DbcWarning>,
) -> (Option<String>, Ranges) {
    let MessageContext {
        message,
        id,
        source,
    } = context;
    let marked = signal.multiplexer_indicator != MultiplexIndicator::Plain;
    let switch = lists.switch_of(&signal.name);
    let values = switch
        .and_then(|switch| lists.listed(switch, &signal.name))
        .cloned()
        .unwrap_or_default();
    let parent = switch.filter(|_| marked).map(str::to_string);
    let has_value = matches!(
        signal.multiplexer_indicator,
        MultiplexIndicator::MultiplexedSignal(_)
            | MultiplexIndicator::MultiplexorAndMultiplexedSignal(_)
    );
    if has_value && parent.is_none() {
        warnings.push(DbcWarning(format!(
            "{source}: message {} ({id}): signal {} is marked multiplexed, but the message has {} multiplexors and no SG_MUL_VAL_ line switches it: decoded in every frame, as cantools does",
            message.name,
            signal.name,
            if multiplexor_count == 0 { "no" } else { "several" }
        )));
    }
    (parent, values)
}

/// Each node's multiplexor as a signal index: the first multiplexor signal
/// of the message with that name, or none.
fn parent_indices(nodes: &[Node], signals: &[SignalCodec]) -> Vec<Option<usize>> {
    nodes
        .iter()
        .map(|node| {
            node.parent.as_ref().and_then(|parent| {
                signals
                    .iter()
                    .zip(nodes)
                    .position(|(s, n)| n.is_multiplexor && s.name == *parent)
            })
        })
        .collect()
}

/// The signals in the order their multiplexors resolve, and which resolve
/// at all: a signal is resolved when its multiplexor is; what is left (a
/// missing multiplexor, a cycle) is in no frame. Each pass resolves at
/// least one more level of the tree.
fn resolution_order(nodes: &[Node], parent_index: &[Option<usize>]) -> (Vec<usize>, Vec<bool>) {
    let mut resolved = vec![false; nodes.len()];
    let mut order: Vec<usize> = Vec::new();
    loop {
        let before = order.len();
        for (index, node) in nodes.iter().enumerate() {
            if resolved[index] {
                continue;
            }
            let ready = match (&node.parent, parent_index[index]) {
                (None, _) => true,
                (Some(_), Some(parent)) => resolved[parent] && parent != index,
                (Some(_), None) => false,
            };
            if ready {
                resolved[index] = true;
                order.push(index);
            }
        }
        if order.len() == before {
            break;
        }
    }
    (order, resolved)
}

/// Sets the [`Presence`] of the resolved signals, in resolution order, and
/// returns a switch for each multiplexor that frames carry.
fn assign_presence(
    nodes: &[Node],
    parent_index: &[Option<usize>],
    order: &[usize],
    signals: &mut [SignalCodec],
) -> Vec<Switch> {
    let mut switch_of_signal: Vec<Option<usize>> = vec![None; signals.len()];
    let mut switches: Vec<Switch> = Vec::new();
    for &index in order {
        let node = &nodes[index];
        signals[index].presence = match parent_index[index].and_then(|p| switch_of_signal[p]) {
            Some(switch) => Presence::Switched {
                switch,
                values: node.values.clone(),
            },
            None if node.parent.is_none() => Presence::Always,
            None => Presence::Never,
        };
        if node.is_multiplexor && signals[index].presence != Presence::Never {
            switch_of_signal[index] = Some(switches.len());
            switches.push(Switch {
                signal: index,
                pages: multiplexor_pages(nodes, &signals[index]),
            });
        }
    }
    switches
}

/// A multiplexor's pages: its signals' values and its value-table keys
/// (which are pages even when they hold no signal), sorted and unique.
fn multiplexor_pages(nodes: &[Node], multiplexor: &SignalCodec) -> Ranges {
    let name = &multiplexor.name;
    let mut pages: Vec<(i128, i128)> = nodes
        .iter()
        .filter(|n| n.parent.as_deref() == Some(name.as_str()))
        .flat_map(|n| n.values.iter().copied())
        .collect();
    pages.extend(
        multiplexor
            .labels
            .iter()
            .map(|&(key, _)| (i128::from(key), i128::from(key))),
    );
    pages.sort_unstable();
    pages.dedup();
    pages
}

/// Marks the unresolved signals as in no frame and warns of every signal
/// that is never decoded.
fn warn_about_never_decoded(
    context: &MessageContext<'_>,
    nodes: &[Node],
    resolved: &[bool],
    signals: &mut [SignalCodec],
    warnings: &mut Vec<DbcWarning>,
) {
    let MessageContext {
        message,
        id,
        source,
    } = context;
    for (index, signal) in signals.iter_mut().enumerate() {
        if !resolved[index] {
            signal.presence = Presence::Never;
        }
        let never = signal.presence == Presence::Never
            || matches!(&signal.presence, Presence::Switched { values, .. } if values.is_empty());
        if never {
            warnings.push(DbcWarning(format!(
                "{source}: message {} ({id}): signal {} is never decoded: its multiplexor {} is not a multiplexor signal that frames carry, or no value selects it (cantools leaves it out too)",
                message.name,
                signal.name,
                nodes[index].parent.as_deref().unwrap_or("?")
            )));
        }
    }
}

/// An error when `raw * factor + offset` is not a finite number for some raw
/// value of the field (a factor of 1e308 on a 16-bit signal, say).
fn check_scaling_range(
    factor: f64,
    offset: f64,
    encoding: Encoding,
    size_bits: u64,
) -> Result<(), String> {
    if !(factor.is_finite() && offset.is_finite()) {
        return Err(format!(
            "factor {factor} and offset {offset} must be finite numbers"
        ));
    }
    let (low, high) = match encoding {
        // A float field's own range is the float's; only the scaling is checked.
        Encoding::Float32 => (f64::from(f32::MIN), f64::from(f32::MAX)),
        Encoding::Float64 => return Ok(()),
        Encoding::Unsigned => (0.0, 2f64.powi(size_bits as i32) - 1.0),
        Encoding::Signed => {
            let half = 2f64.powi(size_bits as i32 - 1);
            (-half, half - 1.0)
        }
    };
    for raw in [low, high] {
        let value = raw * factor + offset;
        if !value.is_finite() {
            return Err(format!(
                "factor {factor} and offset {offset} overflow for the raw value {raw} ({value}); give a scaling whose values fit in a 64-bit float"
            ));
        }
    }
    Ok(())
}

/// Warnings, once per pair or name, for what decodes but is likely a
/// mistake in the DBC: signals that share bits in the same frame, and a
/// signal name used twice in one message.
fn warn_about_suspicious_signals(
    message: &can_dbc::Message,
    id: CanId,
    source: &Arc<str>,
    signals: &[SignalCodec],
    switches: &[Switch],
    warnings: &mut Vec<DbcWarning>,
) {
    // Each signal's way down the multiplexing tree: (switch, the values of
    // it on the way); `None` for a signal no frame carries.
    type Path<'a> = Vec<(usize, &'a [(i128, i128)])>;
    let paths: Vec<Option<Path>> = signals
        .iter()
        .map(|signal| {
            let mut path = Vec::new();
            let mut presence = &signal.presence;
            // A switch's own multiplexor comes earlier in `switches`, so
            // this ends; the bound only makes that plain.
            for _ in 0..=switches.len() {
                match presence {
                    Presence::Always => return Some(path),
                    Presence::Never => return None,
                    Presence::Switched { switch, values } => {
                        path.push((*switch, values.as_slice()));
                        presence = &signals[switches[*switch].signal].presence;
                    }
                }
            }
            None
        })
        .collect();
    // Two signals share a frame unless, at some multiplexor both hang
    // under, their values are disjoint.
    let can_share = |i: usize, j: usize| match (&paths[i], &paths[j]) {
        (Some(first), Some(second)) => first.iter().all(|(switch, mine)| {
            second
                .iter()
                .filter(|(other, _)| other == switch)
                .all(|(_, theirs)| {
                    mine.iter()
                        .any(|&(a, b)| theirs.iter().any(|&(c, d)| a <= d && c <= b))
                })
        }),
        _ => false,
    };
    let bits: Vec<Vec<u8>> = signals
        .iter()
        .map(|signal| {
            let mut payload = vec![0u8; message.size as usize];
            let all_ones = u64::MAX >> (64 - signal.field.length_bits());
            let _ = signal.field.insert(&mut payload, all_ones);
            payload
        })
        .collect();
    for (i, first) in signals.iter().enumerate() {
        for (j, second) in signals.iter().enumerate().skip(i + 1) {
            if first.name == second.name {
                warnings.push(DbcWarning(format!(
                    "{source}: message {} ({id}): signal {} is defined twice; both are decoded, a rig can name only the first",
                    message.name, first.name
                )));
                continue;
            }
            let shared = bits[i].iter().zip(&bits[j]).any(|(a, b)| a & b != 0);
            if shared && can_share(i, j) {
                warnings.push(DbcWarning(format!(
                    "{source}: message {} ({id}): signals {} and {} share bits; each is decoded as declared",
                    message.name, first.name, second.name
                )));
            }
        }
    }
}

fn scaling(factor: f64, offset: f64) -> Scaling {
    // cantools keeps integers exact when factor and offset are integers.
    const EXACT: f64 = 9_007_199_254_740_992.0; // 2^53
    let integral = |x: f64| x.fract() == 0.0 && x.abs() < EXACT;
    if factor == 1.0 && offset == 0.0 {
        Scaling::Identity
    } else if integral(factor) && integral(offset) {
        Scaling::Integer {
            factor: factor as i128,
            offset: offset as i128,
        }
    } else {
        Scaling::Linear { factor, offset }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DBC: &str = r#"VERSION ""

NS_ :

BS_:

BU_: DAQ

BO_ 768 Force: 8 DAQ
 SG_ TipForce : 0|32@1- (1,0) [-100|100] "kN" Vector__XXX
 SG_ Status : 32|8@1+ (1,0) [0|3] "" Vector__XXX

BO_ 2566848513 Temps: 8 DAQ
 SG_ Oil : 7|16@0+ (0.1,-40) [-40|200] "degC" Vector__XXX
 SG_ Mode M : 16|8@1+ (1,0) [0|255] "" Vector__XXX
 SG_ A m0 : 24|8@1+ (2,-100) [0|0] "" Vector__XXX
 SG_ B m1 : 24|16@1- (1,0) [0|0] "" Vector__XXX

SIG_VALTYPE_ 768 TipForce : 1;
VAL_ 768 Status 0 "ok" 1 "overload" 3 "fault";
"#;

    /// EEC1 (PGN 0xF004) and CCVS1 (0xFEF1) as a J1939 DBC states them,
    /// from source address 0xFE at priority 3 and 6, a PDU1 message (PGN
    /// 0xEF00 to destination 0x00) and an 11-bit one, with `attributes` in
    /// place of the fixture's `ProtocolType`.
    fn j1939_dbc(attributes: &str) -> DbcDatabase {
        let text = include_str!("../../fixtures/dbc/j1939_source_fe.dbc");
        assert!(text.contains(PROTOCOL_J1939));
        // An 11-bit message too (a J1939 DBC may hold one; asammdf then
        // matches nothing by PGN, acq still matches the 29-bit ones).
        let plain = "BO_ 256 Plain: 8 ECU\n SG_ Byte : 0|8@1+ (1,0) [0|255] \"\" ECU\n\nCM_ ";
        let text = text
            .replace(PROTOCOL_J1939, attributes)
            .replacen("CM_ ", plain, 1);
        DbcDatabase::parse(&text, "j1939.dbc").unwrap().0
    }

    fn name_of(database: &DbcDatabase, id: CanId) -> Option<&str> {
        database
            .message_index(id)
            .map(|i| database.messages()[i].name.as_str())
    }

    const PROTOCOL_J1939: &str = r#"BA_DEF_  "ProtocolType" STRING ;
BA_DEF_DEF_  "ProtocolType" "";
BA_ "ProtocolType" "J1939";"#;

    #[test]
    fn a_j1939_dbc_matches_a_pgn_from_any_source_address_and_priority() {
        let database = j1939_dbc(PROTOCOL_J1939);
        let extended = |raw| CanId::extended(raw).unwrap();
        assert_eq!(database.j1939_messages(), 3);
        // The stated id, then source 0x00, then priority 6 from 0x31.
        for raw in [0x0CF0_04FE, 0x0CF0_0400, 0x18F0_0431] {
            assert_eq!(name_of(&database, extended(raw)), Some("EEC1"), "{raw:#x}");
        }
        assert_eq!(name_of(&database, extended(0x18FE_F100)), Some("CCVS1"));
        // PDU1: the destination byte is no part of the PGN.
        assert_eq!(
            name_of(&database, extended(0x0CEF_2131)),
            Some("Proprietary")
        );
        // Another PGN, another data page, an 11-bit id: no match.
        assert_eq!(name_of(&database, extended(0x0CF0_0500)), None);
        assert_eq!(name_of(&database, extended(0x0DF0_0400)), None);
        assert_eq!(
            name_of(&database, CanId::standard(0x100).unwrap()),
            Some("Plain")
        );
        assert_eq!(name_of(&database, CanId::standard(0x4FE).unwrap()), None);
        // Exact ids when asked.
        let mut exact = database.clone();
        exact.set_id_matching(IdMatching::ExactIds);
        assert_eq!(name_of(&exact, extended(0x0CF0_04FE)), Some("EEC1"));
        assert_eq!(name_of(&exact, extended(0x0CF0_0400)), None);
    }

    #[test]
    fn a_dbc_declares_j1939_by_protocol_type_or_by_a_messages_frame_format() {
        let extended = |raw| CanId::extended(raw).unwrap();
        // Not declared: exact ids only, as cantools.
        let plain = j1939_dbc("");
        assert_eq!(plain.j1939_messages(), 0);
        assert_eq!(name_of(&plain, extended(0x0CF0_0400)), None);
        // One message's VFrameFormat, as the enum's index or by default.
        let formats = r#"BA_DEF_ BO_  "VFrameFormat" ENUM  "StandardCAN","ExtendedCAN","reserved","J1939PG";"#;
        let one = j1939_dbc(&format!(
            "{formats}\nBA_ \"VFrameFormat\" BO_ 2364540158 3;"
        ));
        assert_eq!(one.j1939_messages(), 1);
        assert_eq!(name_of(&one, extended(0x0CF0_0400)), Some("EEC1"));
        assert_eq!(name_of(&one, extended(0x18FE_F100)), None);
        let by_default = j1939_dbc(&format!(
            "{formats}\nBA_DEF_DEF_ \"VFrameFormat\" \"J1939PG\";"
        ));
        assert_eq!(by_default.j1939_messages(), 3);
        // ProtocolType by default.
        let protocol_default = j1939_dbc(
            "BA_DEF_  \"ProtocolType\" STRING ;\nBA_DEF_DEF_  \"ProtocolType\" \"J1939\";",
        );
        assert_eq!(protocol_default.j1939_messages(), 3);
    }

    #[test]
    fn two_messages_of_one_pgn_match_by_source_address_and_are_named_in_a_warning() {
        let text = format!(
            r#"VERSION ""
NS_ :
BS_:
BU_: A B
BO_ 2364540158 EEC1_A: 8 A
 SG_ EngineSpeed : 24|16@1+ (0.125,0) [0|8031.875] "rpm" A
BO_ 2364539905 EEC1_B: 8 B
 SG_ EngineSpeed : 24|16@1+ (0.125,0) [0|8031.875] "rpm" B
{PROTOCOL_J1939}
"#
        );
        let (database, warnings) = DbcDatabase::parse(&text, "two.dbc").unwrap();
        let extended = |raw| CanId::extended(raw).unwrap();
        assert_eq!(name_of(&database, extended(0x18F0_0401)), Some("EEC1_B"));
        assert_eq!(name_of(&database, extended(0x18F0_04FE)), Some("EEC1_A"));
        assert_eq!(name_of(&database, extended(0x18F0_0400)), Some("EEC1_A"));
        assert!(
            warnings
                .iter()
                .any(|w| w.0.contains("PGN 61444 (0xF004)") && w.0.contains("EEC1_A, EEC1_B")),
            "{warnings:?}"
        );
    }

    #[test]
    fn decodes_floats_scaling_labels_and_multiplexing() {
        let (db, warnings) = DbcDatabase::parse(DBC, "inline.dbc").unwrap();
        assert!(warnings.is_empty());
        let force = db.message(CanId::Standard(0x300)).unwrap();
        let mut payload = [0u8; 8];
        payload[..4].copy_from_slice(&40.6f32.to_le_bytes());
        payload[4] = 1;
        let mut values = Vec::new();
        force.decode(&payload, |i, v| values.push((i, v))).unwrap();
        assert_eq!(
            values,
            vec![
                (0, PhysicalValue::Float(f64::from(40.6f32))),
                (1, PhysicalValue::Integer(1)),
            ]
        );
        assert_eq!(force.signals[1].label(&payload), Some("overload"));

        let temps = db.message(CanId::Extended(0x18FF_0001)).unwrap();
        // Oil raw 0x0312 = 786 -> 38.6 degC; mode 0 selects A: 7*2-100 = -86.
        let payload = [0x03, 0x12, 0x00, 0x07, 0xFF, 0xFF, 0, 0];
        let mut values = Vec::new();
        temps
            .decode(&payload, |i, v| {
                values.push((temps.signals[i].name.as_str(), v))
            })
            .unwrap();
        assert_eq!(
            values,
            vec![
                ("Oil", PhysicalValue::Float(786.0 * 0.1 - 40.0)),
                ("Mode", PhysicalValue::Integer(0)),
                ("A", PhysicalValue::Integer(-86)),
            ]
        );
        let payload = [0x03, 0x12, 0x01, 0xFE, 0xFF, 0, 0, 0];
        let mut names = Vec::new();
        temps
            .decode(&payload, |i, v| {
                names.push((temps.signals[i].name.as_str(), v))
            })
            .unwrap();
        assert_eq!(names[2], ("B", PhysicalValue::Integer(-2)));
        assert!(temps.decode(&payload[..7], |_, _| {}).is_err());
        let unknown_page = [0x03, 0x12, 0x02, 0, 0, 0, 0, 0];
        assert_eq!(
            temps.decode(&unknown_page, |_, _| {}),
            Err(FrameDecodeError::UnknownMultiplexerValue(2))
        );
    }

    #[test]
    fn shortest_form() {
        let text = |v: PhysicalValue| {
            let mut out = Vec::new();
            v.push_shortest(&mut out);
            String::from_utf8(out).unwrap()
        };
        assert_eq!(text(PhysicalValue::Float(100.0)), "100");
        assert_eq!(text(PhysicalValue::Float(0.1)), "0.1");
        assert_eq!(
            text(PhysicalValue::Float(f64::from(116.89f32))),
            "116.88999938964844"
        );
        assert_eq!(
            text(PhysicalValue::Integer(
                -170141183460469231731687303715884105728
            )),
            "-170141183460469231731687303715884105728"
        );
        assert_eq!(text(PhysicalValue::Float(-0.0)), "-0");
        assert_eq!(text(PhysicalValue::Float(1e16)), "1e16");
        // Every power of ten and its neighbours, either sign: no sign but
        // a negative value's and a negative exponent's, and the text reads
        // back as the value.
        for exponent in -323..=308 {
            let power: f64 = format!("1e{exponent}").parse().unwrap();
            for value in [
                power,
                power.next_up(),
                power.next_down(),
                9.999999999999999 * power,
            ] {
                for value in [value, -value] {
                    let written = text(PhysicalValue::Float(value));
                    assert!(!written.contains('+'), "{written}");
                    assert_eq!(written.parse::<f64>().unwrap(), value, "{written}");
                }
            }
        }
        assert_eq!(text(PhysicalValue::Float(-2.5e-7)), "-2.5e-7");
    }

    proptest::proptest! {
        /// An unswitched signal decodes as the general path decodes it:
        /// every signal of the shipped DBCs' messages without multiplexors,
        /// on payloads of every length up to 64 bytes.
        #[test]
        fn an_unswitched_signal_decodes_as_decode_signal(
            payload in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..=64),
        ) {
            for dbc in ["somat_excavator.dbc", "tensile_frame.dbc", "j1939_source_fe.dbc"] {
                let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                    .join("../fixtures/dbc")
                    .join(dbc);
                let (database, _) = DbcDatabase::load(&path).unwrap();
                for message in database.messages() {
                    for index in 0..message.signals.len() {
                        let Some(unswitched) = message.unswitched(index) else {
                            proptest::prop_assert!(!message.switches.is_empty());
                            continue;
                        };
                        let value = |v: PhysicalValue| v.as_f64().to_bits();
                        proptest::prop_assert_eq!(
                            unswitched.decode(&payload).map(|v| v.map(value)),
                            message.decode_signal(&payload, index).map(|v| v.map(value))
                        );
                    }
                }
            }
        }

        /// A linear signal's raw value reaches f64 from 64 bits as it did
        /// from 128: the same value for every length, sign and pattern.
        #[test]
        fn a_raw_value_becomes_the_same_float_through_64_bits_as_through_128(
            raw in proptest::prelude::any::<u64>(),
            bits in 1u64..=64,
            signed in proptest::prelude::any::<bool>(),
        ) {
            let sign = if signed { '-' } else { '+' };
            let text = format!(
                "VERSION \"\"\n\nNS_ :\n\nBS_:\n\nBU_: DAQ\n\nBO_ 768 M: 8 DAQ\n SG_ S : 0|{bits}@1{sign} (0.5,0) [0|0] \"\" Vector__XXX\n"
            );
            let (database, _) = DbcDatabase::parse(&text, "t.dbc").unwrap();
            let codec = &database.messages()[0].signals[0];
            let raw = if bits == 64 { raw } else { raw & ((1 << bits) - 1) };
            proptest::prop_assert_eq!(
                codec.raw_float(raw).to_bits(),
                (codec.raw_integer(raw) as f64).to_bits()
            );
        }

        /// An integer value becomes the f64 it became through 128 bits,
        /// whether it fits 64 bits or not.
        #[test]
        fn an_integer_value_becomes_the_same_float_however_wide(
            value in proptest::prelude::any::<i128>(),
            shift in 0u32..=127,
        ) {
            // Small values as often as wide ones.
            let value = value >> shift;
            proptest::prop_assert_eq!(
                PhysicalValue::Integer(value).as_f64().to_bits(),
                (value as f64).to_bits()
            );
        }

        /// The text is ryu's (what acq wrote before it took zmij, an
        /// independent implementation of the same shortest round trip),
        /// and reads back to the same bits: any bit pattern, NaN and the
        /// infinities included, and float32 values as a DBC's float
        /// signals give them.
        #[test]
        fn shortest_form_is_ryus_and_reads_back(bits in proptest::prelude::any::<u64>()) {
            for value in [f64::from_bits(bits), f64::from(f32::from_bits(bits as u32))] {
                let mut ours = Vec::new();
                push_shortest_f64(&mut ours, value);
                let ours = String::from_utf8(ours).unwrap();
                let mut buffer = ryu::Buffer::new();
                let theirs = buffer.format(value);
                proptest::prop_assert_eq!(&ours, theirs.strip_suffix(".0").unwrap_or(theirs));
                if value.is_finite() {
                    proptest::prop_assert_eq!(ours.parse::<f64>().unwrap().to_bits(), value.to_bits());
                }
            }
        }
    }

    #[test]
    fn duplicate_ids_across_files_name_both() {
        let (mut first, _) = DbcDatabase::parse(DBC, "a.dbc").unwrap();
        let (second, _) = DbcDatabase::parse(DBC, "b.dbc").unwrap();
        let error = first.merge(second).unwrap_err().to_string();
        assert!(
            error.contains("a.dbc") && error.contains("b.dbc"),
            "{error}"
        );
    }

    #[test]
    fn bad_dbc_is_a_syntax_error_naming_the_file() {
        let error = DbcDatabase::parse("BO_ x", "broken.dbc")
            .unwrap_err()
            .to_string();
        assert!(
            error.starts_with("broken.dbc: not a valid DBC file"),
            "{error}"
        );
    }

    /// A DBC with one message of `size` bytes holding `signals` (SG_ lines),
    /// plus whatever `tail` adds after the messages.
    fn dbc_with(size: u32, signals: &str, tail: &str) -> String {
        format!(
            "VERSION \"\"\n\nNS_ :\n\nBS_:\n\nBU_: DAQ\n\nBO_ 256 Probe: {size} DAQ\n{signals}\n{tail}\n"
        )
    }

    #[test]
    fn what_cannot_be_decoded_is_an_error_naming_message_and_signal() {
        let empty = DbcDatabase::parse("", "empty.dbc").unwrap_err().to_string();
        assert!(empty.contains("empty.dbc"), "{empty}");
        let no_messages =
            DbcDatabase::parse("VERSION \"\"\n\nNS_ :\n\nBS_:\n\nBU_: DAQ\n", "none.dbc")
                .unwrap_err()
                .to_string();
        assert!(no_messages.contains("no messages"), "{no_messages}");
        let long = DbcDatabase::parse(
            &dbc_with(200, " SG_ X : 0|8@1+ (1,0) [0|0] \"\" Vector__XXX", ""),
            "long.dbc",
        )
        .unwrap_err()
        .to_string();
        assert!(
            long.contains("Probe") && long.contains("200 bytes") && long.contains("64"),
            "{long}"
        );
        let overflow = DbcDatabase::parse(
            &dbc_with(
                8,
                " SG_ Huge : 0|16@1+ (1e308,0) [0|0] \"\" Vector__XXX",
                "",
            ),
            "huge.dbc",
        )
        .unwrap_err()
        .to_string();
        assert!(
            overflow.contains("Huge") && overflow.contains("overflow"),
            "{overflow}"
        );
        // The same factor on a 1-bit signal stays finite: decodable, accepted.
        assert!(DbcDatabase::parse(
            &dbc_with(8, " SG_ Bit : 0|1@1+ (1e308,0) [0|0] \"\" Vector__XXX", ""),
            "bit.dbc"
        )
        .is_ok());
    }

    #[test]
    fn what_decodes_but_looks_wrong_is_one_warning_each() {
        let text = dbc_with(
            8,
            " SG_ Low : 0|8@1+ (1,0) [0|0] \"\" Vector__XXX\n SG_ Cross : 4|8@1+ (1,0) [0|0] \"\" Vector__XXX\n SG_ Twice : 16|8@1+ (1,0) [0|0] \"\" Vector__XXX\n SG_ Twice : 24|8@1+ (1,0) [0|0] \"\" Vector__XXX",
            "",
        );
        let (db, warnings) = DbcDatabase::parse(&text, "odd.dbc").unwrap();
        let warnings: Vec<&str> = warnings.iter().map(|w| w.0.as_str()).collect();
        assert_eq!(warnings.len(), 2, "{warnings:?}");
        assert!(warnings
            .iter()
            .any(|w| w.contains("Low and Cross share bits")));
        assert!(warnings
            .iter()
            .any(|w| w.contains("Twice is defined twice")));
        // Both overlapping signals still decode as declared.
        let message = db.message(CanId::Standard(256)).unwrap();
        let mut values = Vec::new();
        message
            .decode(&[0xAB, 0xCD, 1, 2, 0, 0, 0, 0], |i, v| values.push((i, v)))
            .unwrap();
        assert_eq!(values[0], (0, PhysicalValue::Integer(0xAB)));
        assert_eq!(values[1], (1, PhysicalValue::Integer(0xDA)));
    }

    #[test]
    fn vectors_placeholder_message_is_skipped_as_cantools_skips_it() {
        let text = dbc_with(
            8,
            " SG_ Real : 0|8@1+ (1,0) [0|0] \"\" Vector__XXX",
            "BO_ 3221225472 VECTOR__INDEPENDENT_SIG_MSG: 0 Vector__XXX\n SG_ Orphan : 0|8@1+ (1,0) [0|0] \"\" Vector__XXX\n",
        );
        let (db, warnings) = DbcDatabase::parse(&text, "vector.dbc").unwrap();
        assert!(warnings.is_empty(), "{warnings:?}");
        assert_eq!(db.messages().len(), 1);
        assert_eq!(db.messages()[0].name, "Probe");
    }

    /// Extended multiplexing's corners, as cantools 45.1.0 decodes this DBC
    /// (checked 2026-11-25): a marked signal no SG_MUL_VAL_ line names is in
    /// every frame; a range written high-low and a switch that is no
    /// multiplexor select nothing; a later line for the same pair replaces
    /// the earlier; value-table keys are pages, compared with the switch's
    /// value as it decodes (so -1 is no page of an unsigned switch).
    #[test]
    fn extended_multiplexing_follows_cantools_corners() {
        let text = dbc_with(
            8,
            " SG_ A M : 0|8@1+ (1,0) [0|0] \"\" Vector__XXX\n SG_ B M : 8|8@1+ (1,0) [0|0] \"\" Vector__XXX\n SG_ Unlisted m1 : 16|8@1+ (1,0) [0|0] \"\" Vector__XXX\n SG_ Reversed m2 : 24|8@1+ (1,0) [0|0] \"\" Vector__XXX\n SG_ ByPlain m3 : 32|8@1+ (1,0) [0|0] \"\" Vector__XXX\n SG_ Plain : 40|8@1+ (1,0) [0|0] \"\" Vector__XXX\n SG_ OnB m4 : 48|8@1+ (1,0) [0|0] \"\" Vector__XXX",
            "VAL_ 256 A -1 \"Minus\" 9 \"Nine\" ;\nSG_MUL_VAL_ 256 Reversed A 5-3;\nSG_MUL_VAL_ 256 ByPlain Plain 1-1;\nSG_MUL_VAL_ 256 OnB B 0-0, 2-2;\nSG_MUL_VAL_ 256 OnB B 4-4;\n",
        );
        let (db, warnings) = DbcDatabase::parse(&text, "ext.dbc").unwrap();
        let warnings: Vec<&str> = warnings.iter().map(|w| w.0.as_str()).collect();
        assert_eq!(warnings.len(), 3, "{warnings:?}");
        assert!(warnings[0].contains("signal Unlisted is marked multiplexed"));
        assert!(warnings[1].contains("signal Reversed is never decoded"));
        assert!(warnings[2].contains("signal ByPlain is never decoded"));
        let message = db.message(CanId::Standard(256)).unwrap();
        let decoded = |a: u8, b: u8| {
            let mut values = Vec::new();
            message
                .decode(&[a, b, 1, 2, 3, 4, 5, 6], |i, v| {
                    values.push((message.signals[i].name.as_str(), v))
                })
                .map(|()| values)
        };
        let int = PhysicalValue::Integer;
        assert_eq!(
            decoded(9, 4).unwrap(),
            [
                ("A", int(9)),
                ("B", int(4)),
                ("Unlisted", int(1)),
                ("Plain", int(4)),
                ("OnB", int(5))
            ]
        );
        for (a, b, refused) in [(9, 0, 0), (255, 4, 255), (4, 4, 4), (9, 1, 1)] {
            assert_eq!(
                decoded(a, b),
                Err(FrameDecodeError::UnknownMultiplexerValue(refused)),
                "A={a} B={b}"
            );
        }
        assert!(message.signals[6].is_multiplexed() && !message.signals[5].is_multiplexed());
    }

    /// An SG_MUL_VAL_ line for a signal without a marker neither switches it
    /// nor adds a page (cantools 45.1.0, checked 2026-11-25): A=0 decodes
    /// all three, A=1 is refused.
    #[test]
    fn a_value_list_for_an_unmarked_signal_changes_nothing() {
        let text = dbc_with(
            8,
            " SG_ A M : 0|8@1+ (1,0) [0|0] \"\" Vector__XXX\n SG_ Listed : 8|8@1+ (1,0) [0|0] \"\" Vector__XXX\n SG_ P m0 : 16|8@1+ (1,0) [0|0] \"\" Vector__XXX",
            "SG_MUL_VAL_ 256 Listed A 1-1;\n",
        );
        let (db, warnings) = DbcDatabase::parse(&text, "unmarked.dbc").unwrap();
        assert!(warnings.is_empty(), "{warnings:?}");
        let message = db.message(CanId::Standard(256)).unwrap();
        let mut count = 0;
        message
            .decode(&[0, 7, 9, 0, 0, 0, 0, 0], |_, _| count += 1)
            .unwrap();
        assert_eq!(count, 3);
        assert_eq!(
            message.decode(&[1, 7, 9, 0, 0, 0, 0, 0], |_, _| {}),
            Err(FrameDecodeError::UnknownMultiplexerValue(1))
        );
    }

    /// cantools (45.1.0, checked 2026-11-24 on this DBC) decodes switch values
    /// 0, 3, 4, 5 as Listed, 1 as Plain, and refuses 2 and 6.
    #[test]
    fn multiplexer_value_lists_select_signals_for_every_listed_value() {
        let text = dbc_with(
            8,
            " SG_ Switch M : 0|8@1+ (1,0) [0|0] \"\" Vector__XXX\n SG_ Listed m0 : 8|8@1+ (1,0) [0|0] \"\" Vector__XXX\n SG_ Plain m1 : 8|16@1+ (1,0) [0|0] \"\" Vector__XXX",
            "SG_MUL_VAL_ 256 Listed Switch 0-0, 3-5;\n",
        );
        let (db, warnings) = DbcDatabase::parse(&text, "mux.dbc").unwrap();
        assert!(warnings.is_empty(), "{warnings:?}");
        let message = db.message(CanId::Standard(256)).unwrap();
        let decoded = |switch: u8| {
            let mut names = Vec::new();
            let result = message.decode(&[switch, 7, 0, 0, 0, 0, 0, 0], |i, _| {
                names.push(message.signals[i].name.clone())
            });
            result.map(|()| names)
        };
        for switch in [0, 3, 4, 5] {
            assert_eq!(
                decoded(switch).unwrap(),
                ["Switch", "Listed"],
                "switch {switch}"
            );
        }
        assert_eq!(decoded(1).unwrap(), ["Switch", "Plain"]);
        assert_eq!(
            decoded(2).unwrap_err(),
            FrameDecodeError::UnknownMultiplexerValue(2)
        );
    }
}
