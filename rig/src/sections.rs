//! The sections that name sensors: cylinders, clock sync, pairs, the
//! specimen, and sensors that would read the same bits.

use acq_can::canopen::PdoMapping;
use toml::Spanned;

use crate::error::RigFindings;
use crate::file::{BusFile, CylinderFile, PairFile};
use crate::lines::line_of;
use crate::profiles::{pressure, SensorKind};
use crate::{
    Bus, BusClock, Cylinder, Sensor, SensorPair, SensorSource, Specimen, PAIR_TOLERANCE_PCT,
};

/// `[[cylinder]]`: each cylinder's bore and its two chambers' pressure sensors.
pub(crate) fn read_cylinders(
    entries: &[Spanned<CylinderFile>],
    sensors: &[Sensor],
    findings: &mut RigFindings,
) -> Vec<Cylinder> {
    let mut cylinders = Vec::new();
    for spanned in entries {
        let line = line_of(findings.text, spanned.span().start);
        let cylinder = spanned.get_ref();
        let find = |sensor_name: &str, chamber: &str| match sensors
            .iter()
            .position(|s| s.name == sensor_name)
        {
            Some(i) if sensors[i].kind == SensorKind::Pressure => Ok(i),
            Some(_) => Err(format!(
                "cylinder '{}': {chamber} sensor '{sensor_name}' is not a pressure sensor",
                cylinder.name
            )),
            None => Err(format!(
                "cylinder '{}': no sensor named '{sensor_name}' for the {chamber} chamber",
                cylinder.name
            )),
        };
        let bore = pressure::CylinderBore::new(cylinder.bore_mm, cylinder.rod_mm)
            .map_err(|e| format!("cylinder '{}': {e}", cylinder.name))
            .and_then(|bore| {
                for (key, tolerance) in [
                    ("bore_tolerance_mm", cylinder.bore_tolerance_mm),
                    ("rod_tolerance_mm", cylinder.rod_tolerance_mm),
                ] {
                    if tolerance.is_some_and(|t| !(t.is_finite() && t >= 0.0 && t < cylinder.rod_mm)) {
                        return Err(format!(
                            "cylinder '{}': {key} = {}: give the diameter's tolerance in mm, at least 0 and well below the rod's diameter",
                            cylinder.name,
                            tolerance.unwrap_or_default()
                        ));
                    }
                }
                Ok(bore)
            });
        match (
            find(&cylinder.head_sensor, "head"),
            find(&cylinder.rod_sensor, "rod"),
            bore,
        ) {
            (Ok(head_sensor), Ok(rod_sensor), Ok(bore)) => cylinders.push(Cylinder {
                name: cylinder.name.clone(),
                bore,
                bore_tolerance_mm: cylinder.bore_tolerance_mm.unwrap_or(0.0),
                rod_tolerance_mm: cylinder.rod_tolerance_mm.unwrap_or(0.0),
                head_sensor,
                rod_sensor,
            }),
            (head, rod, bore) => {
                for message in [head.err(), rod.err(), bore.err()].into_iter().flatten() {
                    findings.report(line, message);
                }
            }
        }
    }
    cylinders
}

/// A bus's `clock_sync`: the signal on this bus and the reference on
/// another, which estimate its clock's offset.
pub(crate) fn resolve_clock_sync(
    entries: &[Spanned<BusFile>],
    buses: &mut [Bus],
    sensors: &[Sensor],
    findings: &mut RigFindings,
) {
    for spanned in entries {
        let line = line_of(findings.text, spanned.span().start);
        let bus = spanned.get_ref();
        let (Some(sync), Some(bus_index)) = (
            &bus.clock_sync,
            buses.iter().position(|b| b.name == bus.name),
        ) else {
            continue;
        };
        let find = |name: &str| sensors.iter().position(|s| s.name == name);
        match (find(&sync.signal), find(&sync.reference)) {
            (Some(signal), Some(reference)) => {
                if sensors[signal].bus != bus_index {
                    findings.report(
                        line,
                        format!(
                            "bus '{}': clock_sync signal '{}' is on bus '{}', not on this bus",
                            bus.name, sync.signal, buses[sensors[signal].bus].name
                        ),
                    );
                } else if sensors[reference].bus == bus_index {
                    findings.report(line, format!("bus '{}': clock_sync reference '{}' must be on another bus (it gives the reference clock)", bus.name, sync.reference));
                } else {
                    buses[bus_index].clock = BusClock::Estimate { signal, reference };
                }
            }
            (signal, reference) => {
                for (found, name) in [(signal, &sync.signal), (reference, &sync.reference)] {
                    if found.is_none() {
                        findings.report(
                            line,
                            format!("bus '{}': clock_sync names no sensor '{name}'", bus.name),
                        );
                    }
                }
            }
        }
    }
}

/// `[[pair]]`: two sensors of one kind that should read alike.
pub(crate) fn read_pairs(
    entries: &[Spanned<PairFile>],
    sensors: &[Sensor],
    findings: &mut RigFindings,
) -> Vec<SensorPair> {
    let mut pairs = Vec::new();
    for spanned in entries {
        let line = line_of(findings.text, spanned.span().start);
        let pair = spanned.get_ref();
        let found: Vec<Option<usize>> = pair
            .sensors
            .iter()
            .map(|name| sensors.iter().position(|s| &s.name == name))
            .collect();
        let tolerance_pct = pair.tolerance_pct.unwrap_or(PAIR_TOLERANCE_PCT);
        let tolerance = pair.tolerance.unwrap_or(0.0);
        if !(tolerance_pct.is_finite()
            && tolerance_pct >= 0.0
            && tolerance.is_finite()
            && tolerance >= 0.0)
        {
            findings.report(
                line,
                "pair: tolerance_pct and tolerance must be numbers >= 0".into(),
            );
            continue;
        }
        match (found[0], found[1]) {
            (Some(a), Some(b)) if a == b => findings.report(
                line,
                format!("pair: '{}' is paired with itself", pair.sensors[0]),
            ),
            (Some(a), Some(b)) if sensors[a].kind != sensors[b].kind => {
                findings.report(
                    line,
                    format!(
                "pair: '{}' measures {} but '{}' measures {}; a pair compares like with like",
                pair.sensors[0], sensors[a].kind.name(), pair.sensors[1], sensors[b].kind.name()
            ),
                )
            }
            (Some(a), Some(b)) => pairs.push(SensorPair {
                sensors: [a, b],
                tolerance_pct,
                tolerance,
                line,
            }),
            _ => {
                for (found, name) in found.iter().zip(&pair.sensors) {
                    if found.is_none() {
                        findings.report(line, format!("pair: no sensor named '{name}'"));
                    }
                }
            }
        }
    }
    pairs
}

/// `[specimen]`: a tensile specimen's diameter and gauge length.
pub(crate) fn read_specimen(
    entry: Option<&Spanned<Specimen>>,
    findings: &mut RigFindings,
) -> Option<Specimen> {
    entry.and_then(|spanned| {
        let specimen = *spanned.get_ref();
        if specimen.diameter_mm > 0.0
            && specimen.gauge_length_mm > 0.0
            && specimen.diameter_mm.is_finite()
            && specimen.gauge_length_mm.is_finite()
        {
            Some(specimen)
        } else {
            findings.report(
                line_of(findings.text, spanned.span().start),
                "specimen: diameter_mm and gauge_length_mm must be positive lengths in mm".into(),
            );
            None
        }
    })
}

/// Two sensors reading the same bits, or a CANopen COB-ID that a DBC message
/// on the same bus also claims, would silently mix values: refuse both.
pub(crate) fn check_overlaps(
    sensors: &[Sensor],
    buses: &[Bus],
    report: &mut impl FnMut(usize, String),
) {
    for (i, a) in sensors.iter().enumerate() {
        for b in &sensors[..i] {
            if a.bus != b.bus {
                continue;
            }
            let same = match (&a.source, &b.source) {
                (
                    SensorSource::Dbc {
                        id: ia,
                        signal: sa,
                        source_address: aa,
                        ..
                    },
                    SensorSource::Dbc {
                        id: ib,
                        signal: sb,
                        source_address: ab,
                        ..
                    },
                ) => ia == ib && sa == sb && aa == ab,
                (
                    SensorSource::Canopen {
                        cob_id: ca,
                        mapping: ma,
                        ..
                    },
                    SensorSource::Canopen {
                        cob_id: cb,
                        mapping: mb,
                        ..
                    },
                ) => {
                    let range = |m: &PdoMapping| {
                        (m.field.end_byte() - m.data_type.size_bytes())..m.field.end_byte()
                    };
                    let (ra, rb) = (range(ma), range(mb));
                    ca == cb && ra.start < rb.end && rb.start < ra.end
                }
                (
                    SensorSource::J1939 {
                        pgn: pa,
                        source_address: xa,
                        spn: na,
                        ..
                    },
                    SensorSource::J1939 {
                        pgn: pb,
                        source_address: xb,
                        spn: nb,
                        ..
                    },
                ) => pa == pb && (xa == xb || xa.is_none() || xb.is_none()) && na.field == nb.field,
                _ => false,
            };
            if same {
                report(a.line, format!("sensor '{}' reads the same value as sensor '{}' (line {}): duplicate id/address", a.name, b.name, b.line));
            }
        }
        if let SensorSource::Canopen { cob_id, .. } = &a.source {
            if let Some(message) = buses[a.bus].dbc.message(*cob_id) {
                report(a.line, format!("sensor '{}': COB-ID {cob_id} is also DBC message '{}' on bus '{}': duplicate id", a.name, message.name, buses[a.bus].name));
            }
        }
    }
}
