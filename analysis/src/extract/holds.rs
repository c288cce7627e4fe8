//! Steady holds: the stretches where the load is held.
//!
//! The load channel is summarised in 100 ms blocks (memory: 10 blocks per
//! second of recording, whatever the sample rate). A block is steady when
//! the standard deviation of the load over the `window` centred on it is
//! below `steady_std`; a hold is a run of steady blocks whose mean load is
//! at least `min_load_fraction` of the load's range (an idle machine is
//! steady too, but holds nothing), trimmed by `settle` at both ends (the
//! ring-out of the build-up) and at least `min_hold` long after trimming.

/// Block length of the load summary, ns.
pub const BLOCK_NS: i64 = 100_000_000;

/// Hold detection settings (defaults in [`HoldOptions::default`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HoldOptions {
    /// Rolling window of the standard deviation, ns (default 1 s).
    pub window_ns: i64,
    /// Largest load std that counts as steady, in the load's unit
    /// (default: 1 % of the load's range over the recording).
    pub steady_std: Option<f64>,
    /// Shortest hold kept, after trimming, ns (default 3 s).
    pub min_hold_ns: i64,
    /// Trimmed from each end of a hold, ns (default 0.5 s).
    pub settle_ns: i64,
    /// Smallest mean load of a hold, as a fraction of the range (default 0.1).
    pub min_load_fraction: f64,
}

impl Default for HoldOptions {
    fn default() -> Self {
        HoldOptions {
            window_ns: 1_000_000_000,
            steady_std: None,
            min_hold_ns: 3_000_000_000,
            settle_ns: 500_000_000,
            min_load_fraction: 0.1,
        }
    }
}

impl HoldOptions {
    /// Refuses settings no hold could be found with; the message names the
    /// command-line option.
    pub fn check(&self) -> Result<(), String> {
        if !(0.0..1.0).contains(&self.min_load_fraction) {
            return Err(format!(
                "--min-load is a fraction of the load's range in [0, 1), got {}",
                self.min_load_fraction
            ));
        }
        if self.steady_std.is_some_and(|s| !(s > 0.0 && s.is_finite())) {
            return Err("--steady-std must be a positive number in the load's unit".into());
        }
        Ok(())
    }
}

/// Default steady threshold as a fraction of the load range.
pub const STEADY_STD_FRACTION_OF_RANGE: f64 = 0.01;

/// A time window on the reference clock.
#[derive(Clone, Debug, PartialEq)]
pub struct Window {
    pub name: String,
    pub start_ns: i64,
    pub end_ns: i64,
}

#[derive(Clone, Copy, Debug, Default)]
struct Block {
    n: u64,
    sum: f64,
    sum_squares: f64,
}

/// Collects the load channel block by block.
#[derive(Clone, Debug, Default)]
pub struct HoldDetector {
    origin_ns: Option<i64>,
    /// Values are shifted by the first one to keep sums of squares exact.
    shift: f64,
    blocks: Vec<Block>,
    /// Samples before the origin (out of order at the very start): ignored.
    pub ignored: u64,
}

/// What detection found, and with which numbers.
#[derive(Clone, Debug, PartialEq)]
pub struct Detection {
    pub holds: Vec<Window>,
    /// Range of the load's 100 ms means (max - min).
    pub load_range: f64,
    pub steady_std: f64,
}

impl HoldDetector {
    pub fn push(&mut self, time_ns: i64, value: f64) {
        let origin = *self.origin_ns.get_or_insert_with(|| {
            self.shift = value;
            time_ns
        });
        if time_ns < origin {
            self.ignored += 1;
            return;
        }
        let index = ((time_ns - origin) / BLOCK_NS) as usize;
        if index >= self.blocks.len() {
            self.blocks.resize(index + 1, Block::default());
        }
        let v = value - self.shift;
        let block = &mut self.blocks[index];
        block.n += 1;
        block.sum += v;
        block.sum_squares += v * v;
    }

    /// The holds, named `hold1`, `hold2`, ... in time order.
    /// Where the load leaves the level it starts at, and where it is last
    /// away from the level it ends at (unix ns): the first 100 ms block
    /// whose mean is more than `tolerance` from the first block's, and the
    /// end of the last block more than `tolerance` from the last block's.
    /// `None` where it never leaves its level.
    pub fn load_departures(&self, tolerance: f64) -> Option<(i64, i64)> {
        let origin = self.origin_ns?;
        let means: Vec<(usize, f64)> = self
            .blocks
            .iter()
            .enumerate()
            .filter(|(_, b)| b.n > 0)
            .map(|(i, b)| (i, b.sum / b.n as f64))
            .collect();
        let (&(_, first), &(_, last)) = (means.first()?, means.last()?);
        let rises = means.iter().find(|(_, m)| (m - first).abs() > tolerance)?.0;
        let settles = means
            .iter()
            .rev()
            .find(|(_, m)| (m - last).abs() > tolerance)?
            .0;
        Some((
            origin + rises as i64 * BLOCK_NS,
            origin + (settles as i64 + 1) * BLOCK_NS,
        ))
    }

    pub fn detect(&self, options: &HoldOptions) -> Detection {
        let Some(origin) = self.origin_ns else {
            return Detection {
                holds: Vec::new(),
                load_range: 0.0,
                steady_std: options.steady_std.unwrap_or(0.0),
            };
        };
        let means: Vec<Option<f64>> = self
            .blocks
            .iter()
            .map(|b| (b.n > 0).then(|| b.sum / b.n as f64))
            .collect();
        let (lo, hi) = means
            .iter()
            .flatten()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &m| {
                (lo.min(m), hi.max(m))
            });
        let load_range = if hi >= lo { hi - lo } else { 0.0 };
        let steady_std = options
            .steady_std
            .unwrap_or(STEADY_STD_FRACTION_OF_RANGE * load_range);
        // Block means are shifted; the idle level is the smaller magnitude end.
        let (lo_abs, hi_abs) = (lo + self.shift, hi + self.shift);
        let idle_level = if lo_abs.abs() <= hi_abs.abs() {
            lo_abs
        } else {
            hi_abs
        };
        let half = ((options.window_ns / BLOCK_NS).max(1) / 2) as usize;
        let steady: Vec<bool> = (0..self.blocks.len())
            .map(|i| {
                let from = i.saturating_sub(half);
                let to = (i + half).min(self.blocks.len() - 1);
                let mut total = Block::default();
                for block in &self.blocks[from..=to] {
                    total.n += block.n;
                    total.sum += block.sum;
                    total.sum_squares += block.sum_squares;
                }
                if total.n < 3 || self.blocks[i].n == 0 {
                    return false;
                }
                let n = total.n as f64;
                let variance = (total.sum_squares - total.sum * total.sum / n) / (n - 1.0);
                variance.max(0.0).sqrt() <= steady_std
            })
            .collect();
        let mut holds = Vec::new();
        let mut i = 0;
        while i < steady.len() {
            if !steady[i] {
                i += 1;
                continue;
            }
            let first = i;
            while i < steady.len() && steady[i] {
                i += 1;
            }
            let (sum, n) = self.blocks[first..i]
                .iter()
                .fold((0.0, 0u64), |(s, n), b| (s + b.sum, n + b.n));
            let mean = sum / n as f64 + self.shift;
            if (mean - idle_level).abs() < options.min_load_fraction * load_range
                || load_range == 0.0
            {
                continue;
            }
            let start_ns = origin + first as i64 * BLOCK_NS + options.settle_ns;
            let end_ns = origin + i as i64 * BLOCK_NS - options.settle_ns;
            if end_ns - start_ns >= options.min_hold_ns {
                holds.push(Window {
                    name: format!("hold{}", holds.len() + 1),
                    start_ns,
                    end_ns,
                });
            }
        }
        Detection {
            holds,
            load_range,
            steady_std,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    /// Idle 2 s, ramp 2 s, hold `hold_s`, ramp 2 s, idle 2 s, at 100 Hz.
    fn load_history(
        detector: &mut HoldDetector,
        level: f64,
        hold_s: f64,
        start_s: f64,
        noise: f64,
    ) -> f64 {
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let noise = Normal::new(0.0, noise).unwrap();
        let total = 8.0 + hold_s;
        let mut t = 0.0;
        while t < total {
            let value = match t {
                t if t < 2.0 => 0.0,
                t if t < 4.0 => level * (t - 2.0) / 2.0,
                t if t < 4.0 + hold_s => level,
                t if t < 6.0 + hold_s => level * (1.0 - (t - 4.0 - hold_s) / 2.0),
                _ => 0.0,
            };
            detector.push(((start_s + t) * 1e9) as i64, value + noise.sample(&mut rng));
            t += 0.01;
        }
        start_s + total
    }

    #[test]
    fn finds_the_hold_inside_the_plateau_and_not_the_idle() {
        let mut detector = HoldDetector::default();
        load_history(&mut detector, 40.6, 8.0, 0.0, 0.08);
        let detection = detector.detect(&HoldOptions::default());
        assert_eq!(detection.holds.len(), 1, "{detection:?}");
        let hold = &detection.holds[0];
        // The plateau is 4..12 s; the hold must lie inside it, trimmed.
        assert!(
            hold.start_ns >= 4_000_000_000 && hold.start_ns <= 5_200_000_000,
            "{hold:?}"
        );
        assert!(
            hold.end_ns <= 12_000_000_000 && hold.end_ns >= 10_800_000_000,
            "{hold:?}"
        );
    }

    #[test]
    fn two_holds_at_two_levels_and_a_too_short_one_dropped() {
        let mut detector = HoldDetector::default();
        let end = load_history(&mut detector, 40.6, 8.0, 0.0, 0.05);
        let end = load_history(&mut detector, 20.0, 6.0, end, 0.05);
        load_history(&mut detector, 30.0, 2.0, end, 0.05);
        let detection = detector.detect(&HoldOptions::default());
        let names: Vec<&str> = detection.holds.iter().map(|h| h.name.as_str()).collect();
        assert_eq!(names, ["hold1", "hold2"], "{detection:?}");
        assert!(detection.holds[1].start_ns > 16_000_000_000 + 4_000_000_000);
    }

    #[test]
    fn a_constant_load_has_no_hold() {
        let mut detector = HoldDetector::default();
        for i in 0..2000 {
            detector.push(i * 10_000_000, 5.0);
        }
        assert!(detector.detect(&HoldOptions::default()).holds.is_empty());
        assert!(HoldDetector::default()
            .detect(&HoldOptions::default())
            .holds
            .is_empty());
    }
}
