//! Plausibility of each sensor's reading in a window: a value is flagged,
//! never silently fed on, when
//! - it has no samples, or too few (`n_eff < 2`) for an interval;
//! - it is stuck: at least 20 bit-identical consecutive readings spanning
//!   2 s or more (a live sensor's noise changes the last bits; a dead
//!   channel or a frozen DAQ value repeats exactly);
//! - it is saturated: readings within 0.1 % of either end of the range the
//!   rig declares (`range = [lo, hi]`);
//! - it is noisy: its standard deviation exceeds 5 times the median of the
//!   sensors of its kind in the same window (needs 3 or more of that kind);
//! - it disagrees with its partner (`[[pair]]` in the rig): the means
//!   differ by more than `tolerance_pct` of the larger magnitude and by more
//!   than `tolerance`. Both partners are flagged: a pair alone cannot say
//!   which one is wrong;
//! - it spikes: readings that jump away from both their neighbours and
//!   back ([`crate::extract::stats::SPIKE_FACTOR`]), a glitch the mean
//!   would carry;
//! - it is unlike its neighbours: in a rig `[[row]]` (sensors in order
//!   along one member), a gauge whose mean lies farther from the line
//!   through its two neighbours than [`NEIGHBOUR_FACTOR`] times what those
//!   two differ by (or a tenth of their size, if more): one gauge at 103 MPa
//!   between neighbours at 34 and 40 MPa is a bonding, wiring or gauge
//!   factor fault far more often than a stress peak that narrow. Check it
//!   (`acq shunt`, the installation) before trusting it. Only declared
//!   rows: `location` numbers alone do not say which gauges are neighbours
//!   on the structure.

use acq_rig::Rig;

use crate::extract::stats::{WindowAccumulator, WindowStats};

pub const STUCK_MIN_RUN: u64 = 20;
pub const STUCK_MIN_SPAN_NS: i64 = 2_000_000_000;
pub const NOISY_FACTOR: f64 = 5.0;
pub const NEIGHBOUR_FACTOR: f64 = 5.0;

/// A flag code and the reason in words.
#[derive(Clone, Debug, PartialEq)]
pub struct Flag {
    pub code: String,
    pub note: String,
}

/// Flags of every sensor in one window (same order as the rig's sensors).
pub fn check_window(
    rig: &Rig,
    accumulators: &[WindowAccumulator],
    stats: &[WindowStats],
) -> Vec<Vec<Flag>> {
    let mut flags: Vec<Vec<Flag>> = vec![Vec::new(); rig.sensors.len()];
    for (index, sensor) in rig.sensors.iter().enumerate() {
        let (acc, s) = (&accumulators[index], &stats[index]);
        let unit = sensor.unit();
        if s.n == 0 {
            flags[index].push(Flag {
                code: "no_samples".into(),
                note: "no sample in this window".into(),
            });
            continue;
        }
        if s.n_eff < 2.0 {
            flags[index].push(Flag {
                code: "few_samples".into(),
                note: format!("{} sample(s), too few for an interval", s.n),
            });
        }
        if acc.longest_identical_run >= STUCK_MIN_RUN
            && acc.longest_identical_span_ns >= STUCK_MIN_SPAN_NS
        {
            flags[index].push(Flag {
                code: "stuck".into(),
                note: format!(
                    "{} identical readings in a row over {:.1} s: a stuck or disconnected channel?",
                    acc.longest_identical_run,
                    acc.longest_identical_span_ns as f64 / 1e9
                ),
            });
        }
        if acc.at_full_scale > 0 {
            if let Some([lo, hi]) = sensor.range {
                flags[index].push(Flag {
                    code: "saturated".into(),
                    note: format!(
                        "{} reading(s) at the end of its range [{lo}, {hi}] {unit}",
                        acc.at_full_scale
                    ),
                });
            }
        }
        if acc.spikes > 0 {
            flags[index].push(Flag {
                code: "spikes".into(),
                note: format!(
                    "{} reading(s) jump away from both neighbours and back, by up to {:.4} {unit}: a glitch on the line? The mean carries them",
                    acc.spikes, acc.largest_spike
                ),
            });
        }
        let mut peers: Vec<f64> = rig
            .sensors
            .iter()
            .zip(stats)
            .filter(|(other, _)| other.kind == sensor.kind)
            .filter_map(|(_, st)| st.std)
            .collect();
        if peers.len() >= 3 {
            peers.sort_by(f64::total_cmp);
            let median = peers[peers.len() / 2];
            if let Some(std) = s.std {
                if median > 0.0 && std > NOISY_FACTOR * median {
                    flags[index].push(Flag {
                        code: "noisy".into(),
                        note: format!(
                            "std {std:.4} {unit}, {:.0} times the median of its kind ({median:.4} {unit})",
                            std / median
                        ),
                    });
                }
            }
        }
    }
    for (index, flag) in unlike_neighbours(rig, stats) {
        flags[index].push(flag);
    }
    for pair in &rig.pairs {
        let [a, b] = pair.sensors;
        let (Some(mean_a), Some(mean_b)) = (stats[a].mean, stats[b].mean) else {
            continue;
        };
        let difference = (mean_a - mean_b).abs();
        let larger = mean_a.abs().max(mean_b.abs());
        let percent = if larger > 0.0 {
            100.0 * difference / larger
        } else {
            0.0
        };
        if percent > pair.tolerance_pct && difference > pair.tolerance {
            let unit = rig.sensors[a].unit();
            for (this, other, other_mean) in [(a, b, mean_b), (b, a, mean_a)] {
                let other_name = &rig.sensors[other].name;
                flags[this].push(Flag {
                    code: format!("pair:{other_name}"),
                    note: format!(
                        "differs from its partner {other_name} ({other_mean:.2} {unit}) by {percent:.0} % (allowed {} % or {} {unit})",
                        pair.tolerance_pct, pair.tolerance
                    ),
                });
            }
        }
    }
    flags
}

/// Each sensor of a rig `[[row]]` whose mean is unlike its neighbours' in
/// the row (see the module's doc), with its flag. Positions along the row
/// are the sensors' `location` numbers when all three have one, else
/// their places in the row.
fn unlike_neighbours(rig: &Rig, stats: &[WindowStats]) -> Vec<(usize, Flag)> {
    let mut flagged = Vec::new();
    for row in &rig.rows {
        for (place, trio) in row.sensors.windows(3).enumerate() {
            let [below, index, above] = [trio[0], trio[1], trio[2]];
            let (Some(m_below), Some(mean), Some(m_above)) =
                (stats[below].mean, stats[index].mean, stats[above].mean)
            else {
                continue;
            };
            let position = |k: usize, fallback: usize| match (
                rig.sensors[below].location,
                rig.sensors[index].location,
                rig.sensors[above].location,
            ) {
                (Some(_), Some(_), Some(_)) => f64::from(rig.sensors[k].location.unwrap_or(0)),
                _ => fallback as f64,
            };
            let (p_below, p, p_above) = (
                position(below, place),
                position(index, place + 1),
                position(above, place + 2),
            );
            if p_above == p_below {
                continue;
            }
            let along = (p - p_below) / (p_above - p_below);
            let expected = m_below + along * (m_above - m_below);
            let scale = (m_above - m_below)
                .abs()
                .max(0.1 * m_below.abs().max(m_above.abs()));
            if scale > 0.0 && (mean - expected).abs() > NEIGHBOUR_FACTOR * scale {
                let unit = rig.sensors[index].unit();
                flagged.push((
                    index,
                    Flag {
                        code: "unlike_neighbours".into(),
                        note: format!(
                            "{mean:.4} {unit} where its neighbours in the row {} ({m_below:.4}) and {} ({m_above:.4}) put it near {expected:.4}: check the gauge (bonding, wiring, gauge factor; acq shunt) before trusting it",
                            rig.sensors[below].name,
                            rig.sensors[above].name
                        ),
                    },
                ));
            }
        }
    }
    flagged
}
