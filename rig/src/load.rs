//! Loading a rig: its buses, then each sensor (where it is on the bus, its
//! unit and conversion), then the sections that name sensors.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

use acq_can::bits::BitField;
use acq_can::canopen::{self, PdoMapping};
use acq_can::dbc::DbcDatabase;
use acq_can::frame::IfaceName;
use acq_can::j1939::Spn;
use toml::Spanned;

use crate::error::{RigError, RigFindings, RigProblem};
use crate::file::{BusFile, RigFile, RigMetaFile, SensorFile};
use crate::lines::line_of;
use crate::profiles::{
    displacement, force, inclination, pressure, strain, Conversion, Linear, ProfileError,
    SensorKind,
};
use crate::record::{read_record, take_transducer_records};
use crate::sections::{
    check_overlaps, read_cylinders, read_pairs, read_specimen, resolve_clock_sync,
};
use crate::{Bus, BusClock, Rig, Sensor, SensorSource, MAX_RATE_HZ};

impl Rig {
    /// Reads, parses and validates a rig file (and the DBC files it names).
    pub fn load(path: &Path) -> Result<Rig, RigError> {
        let fail = |message: String| RigError {
            path: path.to_path_buf(),
            problems: vec![RigProblem {
                line: None,
                message,
            }],
        };
        // A FIFO or a device would block or never end.
        if std::fs::metadata(path).is_ok_and(|m| !m.is_file()) {
            return Err(fail(
                "not a regular file; give the rig file's path".to_string(),
            ));
        }
        let text = std::fs::read_to_string(path)
            .map_err(|e| fail(format!("cannot read the rig file: {e}")))?;
        let base = path.parent().unwrap_or(Path::new("."));
        Self::parse(&text, path, base)
    }

    /// Parses rig text; DBC paths are resolved against `base`.
    pub fn parse(text: &str, path: &Path, base: &Path) -> Result<Rig, RigError> {
        let mut file: RigFile = toml::from_str(text).map_err(|e| RigError {
            path: path.to_path_buf(),
            problems: vec![RigProblem {
                line: e.span().map(|s| line_of(text, s.start)),
                message: e.message().trim().to_string(),
            }],
        })?;
        let mut findings = RigFindings {
            text,
            problems: Vec::new(),
            warnings: Vec::new(),
        };
        if file.sensors.is_empty() {
            findings.report(1, "no [[sensor]] defined: a rig needs at least one".into());
        }
        if file.buses.is_empty() {
            findings.report(
                1,
                "no [[bus]] defined: add one with name, iface (e.g. can0) and its dbc files".into(),
            );
        }
        let mut buses = read_buses(&file.buses, base, &mut findings);
        let sensor_file = file
            .rig
            .as_ref()
            .and_then(|meta| meta.sensor_file.as_deref())
            .map(|name| base.join(name));
        let transducers =
            take_transducer_records(&mut file.sensors, sensor_file.as_deref(), &mut findings);
        let mut sensors = read_sensors(&file.sensors, &buses, &mut findings);
        for sensor in &mut sensors {
            sensor.record.transducer = transducers.get(&sensor.name).cloned();
        }
        let cylinders = read_cylinders(&file.cylinders, &sensors, &mut findings);
        resolve_clock_sync(&file.buses, &mut buses, &sensors, &mut findings);
        let pairs = read_pairs(&file.pairs, &sensors, &mut findings);
        let named: Vec<(&str, SensorKind)> =
            sensors.iter().map(|s| (s.name.as_str(), s.kind)).collect();
        let (rows, row_problems) = crate::rows::read_rows(&file.rows, &named, findings.text);
        for (line, message) in row_problems {
            findings.report(line, message);
        }
        let specimen = read_specimen(file.specimen.as_ref(), &mut findings);
        let RigFindings {
            problems, warnings, ..
        } = findings;

        if !problems.is_empty() {
            return Err(RigError {
                path: path.to_path_buf(),
                problems,
            });
        }
        let meta = file.rig.unwrap_or(RigMetaFile {
            name: None,
            description: None,
            sensor_file: None,
        });
        Ok(Rig {
            name: meta.name.unwrap_or_else(|| {
                path.file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default()
            }),
            description: meta.description,
            path: path.to_path_buf(),
            sensor_file,
            buses,
            sensors,
            cylinders,
            pairs,
            rows,
            specimen,
            warnings,
        })
    }

    /// Points the rig's buses at the interfaces a recording used: unchanged
    /// when every bus's interface is among them (or the rig has one bus),
    /// else bus by bus in order. Returns a note per remapped bus, or why the
    /// interfaces cannot be matched.
    pub fn assign_interfaces(&mut self, interfaces: &[IfaceName]) -> Result<Vec<String>, String> {
        if self.buses.len() == 1 || self.buses.iter().all(|b| interfaces.contains(&b.iface)) {
            return Ok(Vec::new());
        }
        if self.buses.len() != interfaces.len() {
            let names: Vec<String> = self
                .buses
                .iter()
                .map(|b| format!("{} ({})", b.name, b.iface))
                .collect();
            return Err(format!(
                "the rig has buses {} but {} interface(s) were used; give one interface per rig bus, in order",
                names.join(", "),
                interfaces.len()
            ));
        }
        let mut notes = Vec::new();
        for (bus, iface) in self.buses.iter_mut().zip(interfaces) {
            if bus.iface != *iface {
                notes.push(format!(
                    "rig bus {} ({}) recorded on {iface}",
                    bus.name, bus.iface
                ));
                bus.iface = *iface;
            }
        }
        Ok(notes)
    }

    /// Takes frames logged on other interfaces as the rig's buses' (a
    /// logger's `can1` as the rig's `can0`): each `(logged, rig)` pair moves
    /// the bus on interface `rig` to `logged`. All pairs are looked up
    /// before any moves, so `can0=can1` with `can1=can0` swaps two buses.
    /// Errors name the pair: a bad name, no bus on `rig`, two buses on one
    /// logged interface.
    pub fn take_logged_interfaces(&mut self, pairs: &[(String, String)]) -> Result<(), String> {
        let buses: Vec<String> = self
            .buses
            .iter()
            .map(|b| format!("{} on {}", b.name, b.iface))
            .collect();
        let mut moves = Vec::new();
        for (logged, rig) in pairs {
            let pair = format!("--bus {logged}={rig}");
            let name = IfaceName::new(logged)
                .ok_or_else(|| format!("{pair}: '{logged}' is not an interface name"))?;
            let index = self
                .buses
                .iter()
                .position(|b| b.iface.as_str() == rig)
                .ok_or_else(|| {
                    format!(
                        "{pair}: the rig has no bus on {rig} (its buses: {})",
                        buses.join(", ")
                    )
                })?;
            if moves.iter().any(|(earlier, _)| *earlier == index) {
                return Err(format!("{pair}: {rig} is given twice"));
            }
            moves.push((index, name));
        }
        for (index, name) in moves {
            self.buses[index].iface = name;
        }
        let mut seen = std::collections::HashSet::new();
        if let Some(twice) = self.buses.iter().find(|b| !seen.insert(b.iface)) {
            return Err(format!(
                "--bus: two of the rig's buses would be on {}; give each bus its own logged interface",
                twice.iface
            ));
        }
        Ok(())
    }

    pub fn sensor(&self, name: &str) -> Option<(usize, &Sensor)> {
        self.sensors
            .iter()
            .enumerate()
            .find(|(_, s)| s.name == name)
    }

    /// A plain-text account of the rig: what `acq check-rig` prints.
    pub fn explain(&self) -> String {
        let mut text = String::new();
        let _ = writeln!(text, "rig '{}' ({}): OK", self.name, self.path.display());
        if let Some(description) = &self.description {
            let _ = writeln!(text, "  {description}");
        }
        for bus in &self.buses {
            let bitrate = bus
                .bitrate
                .map(|b| format!(", {} kbit/s", b / 1000))
                .unwrap_or_default();
            let _ = writeln!(
                text,
                "bus '{}' on {}{bitrate}: {} DBC messages from {} file(s)",
                bus.name,
                bus.iface,
                bus.dbc.messages().len(),
                bus.dbc_files.len()
            );
        }
        let _ = writeln!(text, "{} sensors:", self.sensors.len());
        for sensor in &self.sensors {
            let address = match &sensor.source {
                SensorSource::Dbc { id, message, signal, .. } => format!("DBC {message}.{signal} (id {id})"),
                SensorSource::Canopen { node_id, pdo, cob_id, mapping, heartbeat_ms } => format!(
                    "CANopen node 0x{node_id:02X} TPDO{pdo} (COB-ID {cob_id}) {} at byte {}, {} decimal digits{}",
                    mapping.data_type.name(),
                    mapping.field.end_byte() - mapping.data_type.size_bytes(),
                    mapping.decimal_digits,
                    heartbeat_ms.map(|h| format!(", heartbeat {h} ms")).unwrap_or_default()
                ),
                SensorSource::J1939 { pgn, source_address, spn_number, spn } => format!(
                    "J1939 PGN {pgn}{} from {}, {} bits x {} + {}",
                    spn_number.map(|n| format!(" SPN {n}")).unwrap_or_default(),
                    source_address.map(|a| format!("SA 0x{a:02X}")).unwrap_or_else(|| "any SA".into()),
                    spn.field.length_bits(),
                    spn.resolution,
                    spn.offset
                ),
            };
            let _ = writeln!(
                text,
                "  {:<24} {:<12} {:>7} Hz  {} -> {}  {}",
                sensor.name,
                sensor.kind.name(),
                sensor.rate_hz,
                sensor.channel_unit,
                sensor.unit(),
                address
            );
        }
        for cylinder in &self.cylinders {
            let _ = writeln!(
                text,
                "cylinder '{}': bore {} mm, rod {} mm, head {} / rod {}",
                cylinder.name,
                cylinder.bore.bore_diameter_mm,
                cylinder.bore.rod_diameter_mm,
                self.sensors[cylinder.head_sensor].name,
                self.sensors[cylinder.rod_sensor].name
            );
        }
        for row in &self.rows {
            let names: Vec<&str> = row
                .sensors
                .iter()
                .map(|&k| self.sensors[k].name.as_str())
                .collect();
            let _ = writeln!(
                text,
                "row {}: each expected near the line through its neighbours",
                names.join(", ")
            );
        }
        for pair in &self.pairs {
            let [a, b] = pair.sensors;
            let _ = writeln!(
                text,
                "pair {} / {}: should agree within {} % (or {} {})",
                self.sensors[a].name,
                self.sensors[b].name,
                pair.tolerance_pct,
                pair.tolerance,
                self.sensors[a].unit()
            );
        }
        for bus in &self.buses {
            match bus.clock {
                BusClock::Reference => {}
                BusClock::OffsetMs(ms) => {
                    let _ = writeln!(
                        text,
                        "bus '{}' clock: {ms} ms ahead of the reference",
                        bus.name
                    );
                }
                BusClock::Estimate { signal, reference } => {
                    let _ = writeln!(
                        text,
                        "bus '{}' clock: offset estimated from {} against {}",
                        bus.name, self.sensors[signal].name, self.sensors[reference].name
                    );
                }
            }
        }
        if let Some(specimen) = &self.specimen {
            let _ = writeln!(
                text,
                "specimen: diameter {} mm ({:.4} mm^2), gauge length {} mm",
                specimen.diameter_mm,
                specimen.area_mm2(),
                specimen.gauge_length_mm
            );
        }
        for warning in &self.warnings {
            let _ = writeln!(text, "warning: {warning}");
        }
        text
    }
}

/// Protocol addressing -> compiled source, plus the channel unit the
/// protocol itself declares (a DBC signal's unit).
pub(crate) fn compile_source(
    sensor: &SensorFile,
    bus: &Bus,
) -> Result<(SensorSource, Option<String>), String> {
    if let Some(address) = &sensor.dbc {
        let Some(message) = bus.dbc.message_by_name(&address.message) else {
            let known: Vec<&str> = bus
                .dbc
                .messages()
                .iter()
                .map(|m| m.name.as_str())
                .take(20)
                .collect();
            return Err(if bus.dbc_files.is_empty() {
                format!(
                    "DBC message '{}' but bus '{}' has no dbc files",
                    address.message, bus.name
                )
            } else {
                format!(
                    "unknown DBC message '{}' on bus '{}' (messages: {})",
                    address.message,
                    bus.name,
                    known.join(", ")
                )
            });
        };
        let Some((signal_index, signal)) = message.signal(&address.signal) else {
            let known: Vec<&str> = message.signals.iter().map(|s| s.name.as_str()).collect();
            return Err(format!(
                "unknown signal '{}' in DBC message '{}' (signals: {})",
                address.signal,
                message.name,
                known.join(", ")
            ));
        };
        let unit = (!signal.unit.is_empty()).then(|| signal.unit.clone());
        if address.source_address.is_some() && message.j1939_pgn.is_none() {
            return Err(format!(
                "source_address is for a J1939 message, and DBC message '{}' is none: its DBC declares no ProtocolType \"J1939\" (nor VFrameFormat J1939PG); remove source_address",
                message.name
            ));
        }
        return Ok((
            SensorSource::Dbc {
                id: message.id,
                message: message.name.clone(),
                signal: signal.name.clone(),
                signal_index,
                j1939_pgn: message.j1939_pgn,
                source_address: address.source_address,
            },
            unit,
        ));
    }
    if let Some(address) = &sensor.canopen {
        let cob_id = canopen::tpdo_cob_id(address.pdo, address.node_id).ok_or_else(|| {
            format!(
                "canopen node_id must be 1..=127 and pdo 1..=4 (TPDO1-4), got node_id {} pdo {}",
                address.node_id, address.pdo
            )
        })?;
        let mapping = PdoMapping::new(address.byte, address.data_type, address.decimal_digits)
            .map_err(|e| format!("canopen mapping: {e}"))?;
        if let Some(period) = address.heartbeat_ms {
            if !(period > 0.0 && period.is_finite()) {
                return Err(format!(
                    "canopen heartbeat_ms must be positive, got {period}"
                ));
            }
        }
        return Ok((
            SensorSource::Canopen {
                node_id: address.node_id,
                pdo: address.pdo,
                cob_id,
                mapping,
                heartbeat_ms: address.heartbeat_ms,
            },
            None,
        ));
    }
    let address = sensor.j1939.as_ref().ok_or("no address")?;
    if address.pgn > 0x3_FFFF {
        return Err(format!("j1939 pgn {} is larger than 18 bits", address.pgn));
    }
    let field = BitField::new(
        acq_can::bits::ByteOrder::LittleEndian,
        address.start_bit,
        address.length_bits,
    )
    .ok()
    .ok_or_else(|| {
        format!(
            "j1939 field of {} bits at bit {} does not fit in 64 bytes (a parameter group longer than 8 bytes comes by the transport protocol; acq reads SPNs in its first 64)",
            address.length_bits, address.start_bit
        )
    })?;
    if !(address.resolution.is_finite() && address.resolution != 0.0 && address.offset.is_finite())
    {
        return Err("j1939 resolution must be a non-zero number and offset a number".into());
    }
    Ok((
        SensorSource::J1939 {
            pgn: address.pgn,
            source_address: address.source_address,
            spn_number: address.spn,
            spn: Spn {
                field,
                resolution: address.resolution,
                offset: address.offset,
            },
        },
        None,
    ))
}

/// The bus a sensor is on: the one it names, or a one-bus rig's. `Err(None)`
/// for a rig with no bus, which is reported once, not per sensor.
fn sensor_bus(sensor: &SensorFile, buses: &[Bus]) -> Result<usize, Option<String>> {
    match (&sensor.bus, buses.len()) {
        (Some(bus_name), _) => buses
            .iter()
            .position(|b| &b.name == bus_name)
            .ok_or_else(|| {
                let known: Vec<&str> = buses.iter().map(|b| b.name.as_str()).collect();
                Some(format!(
                    "unknown bus '{bus_name}' (buses: {})",
                    known.join(", ")
                ))
            }),
        (None, 1) => Ok(0),
        (None, 0) => Err(None),
        (None, _) => Err(Some(
            "the rig has several buses; say which with bus = \"...\"".into(),
        )),
    }
}

/// A sensor's channel unit (the rig file's `unit`, else its DBC signal's,
/// else its kind's) and the unit of its values: its kind's, or for an
/// other quantity the channel's own (acq converts no unit it knows no
/// physics of).
fn sensor_units(
    sensor: &SensorFile,
    default_unit: Option<String>,
) -> Result<(String, String), String> {
    // A DBC signal without a unit states none: "" is no unit.
    let channel_unit = match sensor
        .unit
        .clone()
        .or(default_unit.filter(|unit| !unit.is_empty()))
        .or_else(|| sensor.kind.output_unit().map(str::to_string))
    {
        Some(unit) if !unit.trim().is_empty() => unit,
        _ => return Err("a sensor of kind \"other\" needs its unit, e.g. unit = \"rpm\" or unit = \"degC\" (unit = \"1\" for a plain number); its channel states none".into()),
    };
    let output_unit = sensor
        .kind
        .output_unit()
        .map_or_else(|| channel_unit.clone(), str::to_string);
    Ok((channel_unit, output_unit))
}

pub(crate) fn profile_conversion(sensor: &SensorFile, unit: &str) -> Result<Linear, ProfileError> {
    match sensor.kind {
        SensorKind::Pressure => pressure::to_bar(unit),
        SensorKind::Force => force::to_kilonewton(unit),
        SensorKind::Inclination => inclination::to_degrees(unit),
        SensorKind::Displacement => displacement::to_millimetres(unit, sensor.mm_per_mv_per_v),
        SensorKind::Other => Ok(Linear::scale(1.0)),
        SensorKind::Strain => strain::to_stress_mpa(
            unit,
            strain::StrainChannel {
                youngs_modulus_gpa: sensor.youngs_modulus_gpa.ok_or_else(|| {
                    ProfileError::Invalid(
                        "a strain sensor needs youngs_modulus_gpa (SWS490A steel: 210)".into(),
                    )
                })?,
                gauge_factor: sensor.gauge_factor,
                bridge: sensor.bridge,
            },
        ),
    }
}

/// `[[bus]]`: each bus with its interface, its DBC files merged, and its
/// clock (a `clock_sync`'s sensors are resolved once every sensor is known).
pub(crate) fn read_buses(
    entries: &[Spanned<BusFile>],
    base: &Path,
    findings: &mut RigFindings,
) -> Vec<Bus> {
    let mut buses: Vec<Bus> = Vec::new();
    for spanned in entries {
        let line = line_of(findings.text, spanned.span().start);
        let bus = spanned.get_ref();
        if buses.iter().any(|b| b.name == bus.name) {
            findings.report(line, format!("bus '{}' is defined twice", bus.name));
            continue;
        }
        let Some(iface) = IfaceName::new(&bus.iface) else {
            findings.report(
                line,
                format!(
                    "bus '{}': iface '{}' is not an interface name (1-15 characters, no spaces)",
                    bus.name, bus.iface
                ),
            );
            continue;
        };
        let mut database = DbcDatabase::new();
        let mut dbc_files = Vec::new();
        for relative in &bus.dbc {
            let dbc_path = base.join(relative);
            if !dbc_path.is_file() {
                findings.report(
                    line,
                    format!(
                        "bus '{}': DBC file {} not found (paths are relative to the rig file)",
                        bus.name,
                        dbc_path.display()
                    ),
                );
                continue;
            }
            match DbcDatabase::load(&dbc_path).and_then(|(one, skipped)| {
                database.merge(one)?;
                Ok(skipped)
            }) {
                Ok(skipped) => findings.warnings.extend(skipped.into_iter().map(|w| w.0)),
                Err(e) => findings.report(line, format!("bus '{}': {e}", bus.name)),
            }
            dbc_files.push(dbc_path);
        }
        let clock = match (bus.clock_offset_ms, &bus.clock_sync) {
            (Some(_), Some(_)) => {
                findings.report(
                    line,
                    format!(
                        "bus '{}': give clock_offset_ms or clock_sync, not both",
                        bus.name
                    ),
                );
                BusClock::Reference
            }
            (Some(ms), None) if !ms.is_finite() => {
                findings.report(
                    line,
                    format!(
                        "bus '{}': clock_offset_ms must be a number of milliseconds",
                        bus.name
                    ),
                );
                BusClock::Reference
            }
            (Some(ms), None) => BusClock::OffsetMs(ms),
            // Sensor names are resolved once every sensor is known.
            (None, _) => BusClock::Reference,
        };
        buses.push(Bus {
            name: bus.name.clone(),
            iface,
            bitrate: bus.bitrate,
            dbc_files,
            dbc: database,
            clock,
        });
    }
    buses
}

/// `[[sensor]]`: each sensor once, then the sensors that share an address.
pub(crate) fn read_sensors(
    entries: &[Spanned<SensorFile>],
    buses: &[Bus],
    findings: &mut RigFindings,
) -> Vec<Sensor> {
    let mut sensors: Vec<Sensor> = Vec::new();
    let mut names: HashMap<String, usize> = HashMap::new();
    for spanned in entries {
        let line = line_of(findings.text, spanned.span().start);
        let sensor = spanned.get_ref();
        let name = &sensor.name;
        if let Some(first) = names.insert(name.clone(), line) {
            findings.report(
                line,
                format!("sensor '{name}' is defined twice (first on line {first})"),
            );
            continue;
        }
        if let Some(sensor) = read_sensor(sensor, line, buses, findings) {
            sensors.push(sensor);
        }
    }
    check_overlaps(&sensors, buses, &mut |line, message| {
        findings.report(line, message)
    });
    sensors
}

/// One `[[sensor]]` on `line`: its bus, where it is on the bus, its unit,
/// conversion and range; `None` once a problem is reported.
pub(crate) fn read_sensor(
    sensor: &SensorFile,
    line: usize,
    buses: &[Bus],
    findings: &mut RigFindings,
) -> Option<Sensor> {
    let name = &sensor.name;
    if name.is_empty() || name.contains([',', '"', '\n']) {
        findings.report(line, format!("sensor name '{name}' must be non-empty without commas or quotes (it is a CSV column)"));
        return None;
    }
    if !(sensor.rate_hz > 0.0 && sensor.rate_hz <= MAX_RATE_HZ) {
        findings.report(line, format!("sensor '{name}': rate_hz must be a number of samples per second above 0 and at most {MAX_RATE_HZ} (a CAN FD bus carries fewer frames), got {}", sensor.rate_hz));
    }
    let bus = match sensor_bus(sensor, buses) {
        Ok(bus) => bus,
        Err(message) => {
            if let Some(message) = message {
                findings.report(line, format!("sensor '{name}': {message}"));
            }
            return None;
        }
    };
    let addresses = [
        sensor.dbc.is_some(),
        sensor.canopen.is_some(),
        sensor.j1939.is_some(),
    ];
    if addresses.iter().filter(|&&a| a).count() != 1 {
        findings.report(line, format!("sensor '{name}': give exactly one of dbc = {{ message, signal }}, canopen = {{ node_id, pdo, byte, type }} or j1939 = {{ pgn, start_bit, length_bits, resolution, offset }}"));
        return None;
    }
    let (source, default_unit) = match compile_source(sensor, &buses[bus]) {
        Ok(compiled) => compiled,
        Err(message) => {
            findings.report(line, format!("sensor '{name}': {message}"));
            return None;
        }
    };
    let (channel_unit, output_unit) = match sensor_units(sensor, default_unit) {
        Ok(units) => units,
        Err(message) => {
            findings.report(line, format!("sensor '{name}': {message}"));
            return None;
        }
    };
    let physics = match profile_conversion(sensor, &channel_unit) {
        Ok(physics) => physics,
        Err(e) => {
            findings.report(line, format!("sensor '{name}': {e}"));
            return None;
        }
    };
    let record = match read_record(sensor, &output_unit) {
        Ok(record) => record,
        Err(message) => {
            findings.report(line, format!("sensor '{name}': {message}"));
            return None;
        }
    };
    let calibration = Linear {
        gain: sensor.scale.unwrap_or(1.0),
        offset: sensor.offset.unwrap_or(0.0),
    };
    if !(calibration.gain.is_finite() && calibration.gain != 0.0 && calibration.offset.is_finite())
    {
        findings.report(
            line,
            format!("sensor '{name}': scale must be a non-zero number and offset a number"),
        );
        return None;
    }
    if let Some([lo, hi]) = sensor.range {
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            findings.report(line, format!("sensor '{name}': range must be [low, high] with low < high in {output_unit}, got [{lo}, {hi}]"));
            return None;
        }
    }
    Some(Sensor {
        name: name.clone(),
        kind: sensor.kind,
        bus,
        source,
        channel_unit,
        output_unit,
        rate_hz: sensor.rate_hz,
        // The certificate's points take the reading to the kind's unit
        // themselves: the physics is in them.
        conversion: match (&record.polynomial, &record.curve) {
            (Some(polynomial), _) => Conversion::Polynomial(polynomial.coefficients.clone()),
            (None, Some(curve)) => Conversion::Linear(Linear {
                gain: curve.slope,
                offset: curve.intercept - curve.slope * curve.reading_mean,
            }),
            (None, None) => Conversion::Linear(physics.after(calibration)),
        },
        location: sensor.location,
        description: sensor.description.clone(),
        interpolation: sensor.interpolation.unwrap_or_default(),
        range: sensor.range,
        record,
        zero_at_rest: sensor
            .zero_at_rest
            .unwrap_or(sensor.kind.reads_zero_at_rest()),
        line,
    })
}
