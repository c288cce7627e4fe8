//! Statistics of one sensor over one window, in one pass: mean and
//! standard deviation (Welford), the lag-1 autocorrelation that turns `n`
//! into an effective sample count, the longest run of bit-identical
//! readings (a stuck channel) and the readings at full scale.

use acq_metrology::budget::LEVEL_95;

/// Accumulates the samples of one sensor in one window.
#[derive(Clone, Debug, Default)]
pub struct WindowAccumulator {
    n: u64,
    mean: f64,
    /// Sum of squared deviations from the running mean.
    m2: f64,
    /// For the lag-1 autocovariance: sums over consecutive pairs, shifted
    /// by the first value to keep the cancellation small.
    shift: f64,
    sum_pair_products: f64,
    sum_first_of_pairs: f64,
    sum_second_of_pairs: f64,
    previous: Option<f64>,
    /// Longest run of bit-identical consecutive readings, and the current one.
    run: u64,
    run_start_ns: i64,
    pub longest_identical_run: u64,
    pub longest_identical_span_ns: i64,
    /// Readings within the top or bottom 0.1 % of the declared range.
    pub at_full_scale: u64,
    range: Option<[f64; 2]>,
    /// The reading before `previous`, for spikes.
    before_previous: Option<f64>,
    /// Readings that jump away from both neighbours and back
    /// ([`SPIKE_FACTOR`]), and the largest jump.
    pub spikes: u64,
    pub largest_spike: f64,
}

/// A spike: a reading farther than this many of the window's standard
/// deviations from both its neighbours, on one side of both, while the two
/// neighbours agree within half that jump. Gaussian noise does that about
/// once in 1e15 readings; a glitch on the line (a bit error, a ground
/// loop's pulse) does it every time.
pub const SPIKE_FACTOR: f64 = 8.0;

/// Readings a window needs before a spike can be told from its noise.
const SPIKE_MIN_READINGS: u64 = 10;

/// Fraction of the span near each end of the range that counts as full scale.
const FULL_SCALE_MARGIN: f64 = 0.001;

impl WindowAccumulator {
    pub fn new(range: Option<[f64; 2]>) -> Self {
        WindowAccumulator {
            range,
            ..Default::default()
        }
    }

    pub fn push(&mut self, time_ns: i64, value: f64) {
        self.check_spike(value);
        if self.n == 0 {
            self.shift = value;
        }
        self.n += 1;
        let delta = value - self.mean;
        self.mean += delta / self.n as f64;
        self.m2 += delta * (value - self.mean);
        let shifted = value - self.shift;
        match self.previous {
            Some(previous) => {
                let previous_shifted = previous - self.shift;
                self.sum_pair_products += previous_shifted * shifted;
                self.sum_first_of_pairs += previous_shifted;
                self.sum_second_of_pairs += shifted;
                if previous.to_bits() == value.to_bits() {
                    self.run += 1;
                } else {
                    self.run = 1;
                    self.run_start_ns = time_ns;
                }
            }
            None => {
                self.run = 1;
                self.run_start_ns = time_ns;
            }
        }
        if self.run > self.longest_identical_run {
            self.longest_identical_run = self.run;
        }
        self.longest_identical_span_ns = self
            .longest_identical_span_ns
            .max(time_ns - self.run_start_ns);
        self.before_previous = self.previous;
        self.previous = Some(value);
        if let Some([lo, hi]) = self.range {
            let margin = (hi - lo) * FULL_SCALE_MARGIN;
            if value >= hi - margin || value <= lo + margin {
                self.at_full_scale += 1;
            }
        }
    }

    /// Whether the previous reading, now that `next` follows it, was a
    /// spike ([`SPIKE_FACTOR`]).
    fn check_spike(&mut self, next: f64) {
        let (Some(before), Some(middle)) = (self.before_previous, self.previous) else {
            return;
        };
        if self.n < SPIKE_MIN_READINGS {
            return;
        }
        let std = (self.m2 / (self.n - 1) as f64).max(0.0).sqrt();
        let (up, down) = (middle - before, middle - next);
        let jump = up.abs().min(down.abs());
        if up.signum() == down.signum()
            && jump > SPIKE_FACTOR * std
            && (next - before).abs() < 0.5 * jump
        {
            self.spikes += 1;
            self.largest_spike = self
                .largest_spike
                .max((middle - 0.5 * (before + next)).abs());
        }
    }

    pub fn n(&self) -> u64 {
        self.n
    }

    /// Mean, std, effective n and the 95 % interval of the mean.
    pub fn summary(&self) -> WindowStats {
        let n = self.n;
        if n == 0 {
            return WindowStats::default();
        }
        let mean = self.mean;
        let variance = if n > 1 { self.m2 / (n - 1) as f64 } else { 0.0 };
        let std = variance.max(0.0).sqrt();
        // Lag-1 autocorrelation of the series (shifted values).
        let pairs = (n - 1) as f64;
        let shifted_mean = mean - self.shift;
        let autocorrelation = if n > 2 && self.m2 > 0.0 {
            let covariance = self.sum_pair_products
                - shifted_mean * (self.sum_first_of_pairs + self.sum_second_of_pairs)
                + pairs * shifted_mean * shifted_mean;
            (covariance / self.m2).clamp(-0.99, 0.99)
        } else {
            0.0
        };
        // AR(1) effective sample size; never more than n (negative
        // correlation does not buy extra samples).
        let n_eff = if autocorrelation > 0.0 {
            (n as f64 * (1.0 - autocorrelation) / (1.0 + autocorrelation)).max(1.0)
        } else {
            n as f64
        };
        let ci95_half_width = (n_eff >= 2.0).then(|| {
            let t = acq_metrology::budget::coverage_factor(Some(n_eff - 1.0), LEVEL_95);
            t * std / n_eff.sqrt()
        });
        WindowStats {
            n,
            mean: Some(mean),
            std: (n > 1).then_some(std),
            n_eff,
            lag1_autocorrelation: autocorrelation,
            ci95_half_width,
        }
    }
}

/// The numbers of one sensor in one window.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct WindowStats {
    pub n: u64,
    pub mean: Option<f64>,
    /// Sample standard deviation (n - 1).
    pub std: Option<f64>,
    /// n corrected for lag-1 autocorrelation: `n (1 - r) / (1 + r)`.
    pub n_eff: f64,
    pub lag1_autocorrelation: f64,
    /// Student-t 95 % half width of the mean with `n_eff - 1` degrees of freedom.
    pub ci95_half_width: Option<f64>,
}

impl WindowStats {
    /// The standard error of the mean: `std / sqrt(n_eff)`.
    pub fn std_of_mean(&self) -> Option<f64> {
        Some(self.std? / self.n_eff.max(1.0).sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    /// A hold of Gaussian noise (sd 0.15 MPa around 30 MPa) with two
    /// glitches (+5 and -3 MPa for one reading each) gives exactly those
    /// two spikes and the larger's size; 200,000 readings of the noise
    /// alone, a step (a load change) and a slow ramp give none.
    #[test]
    fn a_glitch_is_a_spike_and_noise_steps_and_ramps_are_not() {
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let noise = Normal::new(0.0, 0.15).unwrap();
        let mut acc = WindowAccumulator::new(None);
        for i in 0..500 {
            let glitch = match i {
                200 => 5.0,
                350 => -3.0,
                _ => 0.0,
            };
            acc.push(i, 30.0 + noise.sample(&mut rng) + glitch);
        }
        assert_eq!(acc.spikes, 2);
        assert!(
            (acc.largest_spike - 5.0).abs() < 1.0,
            "{}",
            acc.largest_spike
        );
        let mut quiet = WindowAccumulator::new(None);
        for i in 0..200_000 {
            let step = if i > 100_000 { 20.0 } else { 0.0 };
            let ramp = 1e-4 * i as f64;
            quiet.push(i, 30.0 + noise.sample(&mut rng) + step + ramp);
        }
        assert_eq!(quiet.spikes, 0);
    }

    #[test]
    fn mean_and_std_of_known_values() {
        let mut acc = WindowAccumulator::new(None);
        for (i, v) in [2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0].iter().enumerate() {
            acc.push(i as i64, *v);
        }
        let stats = acc.summary();
        assert_eq!(stats.n, 8);
        assert!((stats.mean.unwrap() - 5.0).abs() < 1e-15);
        // Sample std: sqrt(32 / 7).
        assert!((stats.std.unwrap() - (32.0f64 / 7.0).sqrt()).abs() < 1e-14);
    }

    #[test]
    fn interval_covers_the_true_mean_95_percent_of_the_time_for_white_noise() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let noise = Normal::new(0.0, 0.3).unwrap();
        let trials = 2000;
        let mut covered = 0;
        for _ in 0..trials {
            let mut acc = WindowAccumulator::new(None);
            for i in 0..50 {
                acc.push(i, 116.89 + noise.sample(&mut rng));
            }
            let s = acc.summary();
            let half = s.ci95_half_width.unwrap();
            if (s.mean.unwrap() - 116.89).abs() <= half {
                covered += 1;
            }
        }
        let rate = covered as f64 / trials as f64;
        // Binomial std of the rate: sqrt(.95 .05 / 2000) = 0.5 %.
        assert!((rate - 0.95).abs() < 0.02, "coverage {rate}");
    }

    #[test]
    fn correlated_noise_widens_the_interval_to_keep_its_coverage() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let noise = Normal::new(0.0, 1.0).unwrap();
        let phi: f64 = 0.8;
        let trials = 1000;
        let mut covered = 0;
        let mut naive_covered = 0;
        let mut sum_autocorrelation = 0.0;
        for _ in 0..trials {
            let mut acc = WindowAccumulator::new(None);
            let mut x = noise.sample(&mut rng) / (1.0 - phi * phi).sqrt();
            for i in 0..800 {
                x = phi * x + noise.sample(&mut rng);
                acc.push(i, x);
            }
            let s = acc.summary();
            sum_autocorrelation += s.lag1_autocorrelation;
            if s.mean.unwrap().abs() <= s.ci95_half_width.unwrap() {
                covered += 1;
            }
            if s.mean.unwrap().abs() <= 1.96 * s.std.unwrap() / (s.n as f64).sqrt() {
                naive_covered += 1;
            }
        }
        let mean_autocorrelation = sum_autocorrelation / trials as f64;
        assert!(
            (mean_autocorrelation - phi).abs() < 0.01,
            "{mean_autocorrelation}"
        );
        let rate = covered as f64 / trials as f64;
        let naive = naive_covered as f64 / trials as f64;
        assert!((rate - 0.95).abs() < 0.03, "coverage {rate}");
        assert!(naive < 0.7, "the naive interval should undercover: {naive}");
    }

    #[test]
    fn a_stuck_channel_shows_as_a_long_identical_run() {
        let mut acc = WindowAccumulator::new(Some([-10.0, 250.0]));
        for i in 0..100 {
            let value = if i < 30 { i as f64 * 0.1 } else { 249.9 };
            acc.push(i * 10_000_000, value);
        }
        assert_eq!(acc.longest_identical_run, 70);
        assert_eq!(acc.longest_identical_span_ns, 69 * 10_000_000);
        assert_eq!(acc.at_full_scale, 70);
        let empty = WindowAccumulator::new(None).summary();
        assert_eq!(empty.mean, None);
        assert_eq!(empty.ci95_half_width, None);
    }
}
