//! Each bus's clock against the reference clock: an offset given on the
//! command line or in the rig, or estimated by cross-correlating a signal
//! both buses see ([`super::offset`]). Every pass over a recording
//! (align, extract) removes these offsets first, so every sample is on the
//! reference clock.

use acq_error::{AcqError, Result};
use acq_rig::{BusClock, Rig};

use super::offset::{estimate_offset, OffsetEstimate, DEFAULT_MAX_LAG_NS, MAX_WINDOW_NS};
use super::{Recording, SampleCounts};

/// Where a bus's clock offset came from.
#[derive(Clone, Debug, PartialEq)]
pub enum ClockSource {
    Reference,
    Given,
    Estimated {
        estimate: OffsetEstimate,
        signal: String,
        reference: String,
    },
}

/// One bus's clock offset.
#[derive(Clone, Debug, PartialEq)]
pub struct BusOffset {
    pub bus: String,
    pub offset_ns: i64,
    pub source: ClockSource,
}

impl std::fmt::Display for BusOffset {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let ms = self.offset_ns as f64 / 1e6;
        match &self.source {
            ClockSource::Reference => write!(f, "bus {}: reference clock", self.bus),
            ClockSource::Given => write!(f, "bus {}: clock offset {ms:+.3} ms (given)", self.bus),
            ClockSource::Estimated { estimate, signal, reference } => write!(
                f,
                "bus {}: clock offset {ms:+.3} ms +- {:.3} ms estimated from {signal} against {reference} (peak correlation {:.4}, confidence {}, {} samples)",
                self.bus,
                estimate.standard_error_ns / 1e6,
                estimate.correlation,
                estimate.confidence(),
                estimate.samples
            ),
        }
    }
}

impl Recording {
    /// Each bus's clock offset: given (`overrides_ms`, from the command line),
    /// in the rig, or estimated (one extra pass over the recording's first
    /// ten minutes).
    pub fn clock_offsets(&self, overrides_ms: &[(String, f64)]) -> Result<Vec<BusOffset>> {
        let recording = self;
        let rig = &recording.rig;
        for (name, _) in overrides_ms {
            if !rig.buses.iter().any(|b| &b.name == name) {
                let names: Vec<&str> = rig.buses.iter().map(|b| b.name.as_str()).collect();
                return Err(AcqError::Config(format!(
                    "--clock-offset names bus '{name}', but the rig's buses are {}",
                    names.join(", ")
                )));
            }
        }
        let mut offsets: Vec<BusOffset> = rig
            .buses
            .iter()
            .map(|bus| {
                let given = overrides_ms
                    .iter()
                    .find(|(name, _)| name == &bus.name)
                    .map(|(_, ms)| *ms);
                let (offset_ns, source) = match (given, &bus.clock) {
                    (Some(ms), _) | (None, &BusClock::OffsetMs(ms)) => {
                        ((ms * 1e6).round() as i64, ClockSource::Given)
                    }
                    _ => (0, ClockSource::Reference),
                };
                BusOffset {
                    bus: bus.name.clone(),
                    offset_ns,
                    source,
                }
            })
            .collect();
        let to_estimate: Vec<(usize, usize, usize)> = rig
            .buses
            .iter()
            .enumerate()
            .filter_map(|(i, bus)| match bus.clock {
                BusClock::Estimate { signal, reference }
                    if offsets[i].source != ClockSource::Given =>
                {
                    Some((i, signal, reference))
                }
                _ => None,
            })
            .collect();
        if to_estimate.is_empty() {
            return Ok(offsets);
        }
        // Reference signals are read with their own bus's (given) offset.
        let base: Vec<i64> = offsets.iter().map(|o| o.offset_ns).collect();
        let mut series: Vec<Vec<(i64, f64)>> = vec![Vec::new(); rig.sensors.len()];
        let wanted: Vec<usize> = to_estimate.iter().flat_map(|&(_, s, r)| [s, r]).collect();
        let horizon = MAX_WINDOW_NS + 2 * DEFAULT_MAX_LAG_NS;
        let mut counts = SampleCounts::default();
        recording.for_each_sample(&base, &mut counts, |sample| {
            if wanted.contains(&sample.sensor) {
                let list = &mut series[sample.sensor];
                let within = list
                    .first()
                    .is_none_or(|(t0, _)| sample.time_ns - t0 <= horizon);
                if let (Some(v), true) = (sample.value, within) {
                    list.push((sample.time_ns, v));
                }
            }
            Ok(())
        })?;
        for (bus, signal, reference) in to_estimate {
            for list in [signal, reference] {
                series[list].sort_by_key(|(t, _)| *t);
            }
            let (signal_name, reference_name) =
                (&rig.sensors[signal].name, &rig.sensors[reference].name);
            let estimate = estimate_offset(&series[signal], &series[reference], DEFAULT_MAX_LAG_NS)
            .map_err(|e| {
                AcqError::Config(format!(
                    "bus {}: cannot estimate the clock offset from {signal_name} against {reference_name}: {e}; give clock_offset_ms in the rig or --clock-offset {}=MS",
                    rig.buses[bus].name, rig.buses[bus].name
                ))
            })?;
            offsets[bus].offset_ns = estimate.offset_ns.round() as i64;
            offsets[bus].source = ClockSource::Estimated {
                estimate,
                signal: signal_name.clone(),
                reference: reference_name.clone(),
            };
        }
        Ok(offsets)
    }
}

/// Each rig bus's clock offset as the rig gives it: what a live reader
/// can remove, with no recording to estimate one from (0 where it is to be
/// estimated or is the reference), ns.
pub fn given_offsets_ns(rig: &Rig) -> Vec<i64> {
    rig.buses
        .iter()
        .map(|bus| match bus.clock {
            BusClock::OffsetMs(ms) => (ms * 1e6).round() as i64,
            _ => 0,
        })
        .collect()
}

/// The offsets to remove, per bus, ns.
pub fn offsets_ns(clocks: &[BusOffset]) -> Vec<i64> {
    clocks.iter().map(|c| c.offset_ns).collect()
}
