//! Zero-phase low-pass filter on the aligned rows: a Gaussian kernel.
//!
//! Why Gaussian: it is the one low-pass whose step response never
//! overshoots, so a filtered hold plateau is never read above its true
//! value. Being symmetric it shifts nothing in time (zero phase), at the
//! price of being acausal: a step at t starts to show before t.
//!
//! With the -3 dB cut-off `fc`, the kernel's standard deviation is
//! `sigma = sqrt(ln 2) / (2 pi fc) = 0.1325 / fc`, and a step becomes
//! `Phi(t / sigma)`: it rises from 10 % to 90 % in `0.3396 / fc`, starting
//! `0.17 / fc` before the step (e.g. fc = 5 Hz: 68 ms rise, 34 ms early).
//!
//! Gaps stay gaps: an empty cell stays empty, and a value next to a gap is
//! the weighted mean of the valid neighbours only (normalised convolution).
//! The kernel is cut at 4 sigma.

use std::collections::VecDeque;

use super::RowSink;

/// `sigma / (1 / fc)`: the Gaussian whose gain is 1/sqrt(2) at fc.
pub const SIGMA_TIMES_CUTOFF: f64 = 0.132_505_608_844_390_3; // sqrt(ln 2) / (2 pi)

/// 10-90 % rise time of the step response times the cut-off.
pub const RISE_TIME_TIMES_CUTOFF: f64 = 2.0 * 1.281_551_565_545 * SIGMA_TIMES_CUTOFF;

/// Filters every channel and passes the rows on, `half_width` rows late.
pub struct GaussianFilter<S> {
    inner: S,
    weights: Vec<f64>,
    half_width: u64,
    /// Consecutive rows, from `next_row - half_width` (or the first) on.
    window: VecDeque<(u64, Vec<Option<f64>>)>,
    /// The next row to write, once its right-hand neighbours are in.
    next_row: Option<u64>,
    out: Vec<Option<f64>>,
}

impl<S: RowSink> GaussianFilter<S> {
    /// A filter with -3 dB cut-off `cutoff_hz` for rows at `rate_hz`.
    /// The cut-off must lie below the grid's Nyquist frequency.
    pub fn new(inner: S, cutoff_hz: f64, rate_hz: f64) -> Result<Self, String> {
        if !(cutoff_hz > 0.0 && cutoff_hz < rate_hz / 2.0) {
            return Err(format!(
                "the filter cut-off must be above 0 and below half the grid rate ({} Hz), got {cutoff_hz} Hz",
                rate_hz / 2.0
            ));
        }
        let sigma_rows = SIGMA_TIMES_CUTOFF / cutoff_hz * rate_hz;
        let half_width = (4.0 * sigma_rows).ceil() as u64;
        let weights = (0..=2 * half_width)
            .map(|i| {
                let x = i as f64 - half_width as f64;
                (-0.5 * (x / sigma_rows).powi(2)).exp()
            })
            .collect();
        Ok(GaussianFilter {
            inner,
            weights,
            half_width,
            window: VecDeque::new(),
            next_row: None,
            out: Vec::new(),
        })
    }

    pub fn into_inner(self) -> S {
        self.inner
    }

    /// Writes row `row`, which must be in the window.
    fn emit(&mut self, row: u64) -> Result<(), S::Error> {
        let first = self.window.front().map_or(row, |(r, _)| *r);
        let center = (row - first) as usize;
        let (_, values) = &self.window[center];
        self.out.clear();
        for (channel, value) in values.iter().enumerate() {
            if value.is_none() {
                self.out.push(None);
                continue;
            }
            let (mut sum, mut weight_sum) = (0.0, 0.0);
            let from = center.saturating_sub(self.half_width as usize);
            let to = (center + self.half_width as usize).min(self.window.len() - 1);
            for i in from..=to {
                if let Some(v) = self.window[i].1[channel] {
                    let w = self.weights[i + self.half_width as usize - center];
                    sum += w * v;
                    weight_sum += w;
                }
            }
            self.out.push(Some(sum / weight_sum));
        }
        self.inner.row(row, &self.out)
    }

    /// Writes every row still held, the kernel cut at the data's end.
    fn flush(&mut self) -> Result<(), S::Error> {
        if let (Some(mut row), Some((last, _))) = (self.next_row, self.window.back()) {
            let last = *last;
            while row <= last {
                self.emit(row)?;
                row += 1;
            }
        }
        self.window.clear();
        self.next_row = None;
        Ok(())
    }
}

impl<S: RowSink> RowSink for GaussianFilter<S> {
    type Error = S::Error;

    fn row(&mut self, row: u64, values: &[Option<f64>]) -> Result<(), S::Error> {
        // Rows arrive consecutively; a jump (never from the aligner) restarts.
        if self.window.back().is_some_and(|(last, _)| *last + 1 != row) {
            self.flush()?;
        }
        self.window.push_back((row, values.to_vec()));
        let mut next = *self.next_row.get_or_insert(row);
        while next + self.half_width <= row {
            self.emit(next)?;
            next += 1;
        }
        self.next_row = Some(next);
        while self
            .window
            .front()
            .is_some_and(|(first, _)| first + self.half_width < next)
        {
            self.window.pop_front();
        }
        Ok(())
    }

    fn finish(&mut self) -> Result<(), S::Error> {
        self.flush()?;
        self.inner.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::align::CollectRows as Collect;

    /// Standard normal CDF by the Abramowitz-Stegun 7.1.26 erf (|error| < 1.5e-7).
    fn phi(x: f64) -> f64 {
        let z = x.abs() / std::f64::consts::SQRT_2;
        let t = 1.0 / (1.0 + 0.327_591_1 * z);
        let poly = t
            * (0.254_829_592
                + t * (-0.284_496_736
                    + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
        let erf = 1.0 - poly * (-z * z).exp();
        if x >= 0.0 {
            0.5 * (1.0 + erf)
        } else {
            0.5 * (1.0 - erf)
        }
    }

    #[test]
    fn a_step_becomes_the_normal_cdf_without_overshoot() {
        let (rate_hz, cutoff_hz) = (1000.0, 5.0);
        let mut filter = GaussianFilter::new(Collect::default(), cutoff_hz, rate_hz).unwrap();
        for row in 0..2000u64 {
            let value = if row >= 1000 { 1.0 } else { 0.0 };
            filter.row(row, &[Some(value)]).unwrap();
        }
        filter.finish().unwrap();
        let rows = filter.into_inner().0;
        assert_eq!(rows.len(), 2000);
        let sigma_s = SIGMA_TIMES_CUTOFF / cutoff_hz;
        for (row, values) in &rows {
            let v = values[0].unwrap();
            assert!((-1e-12..=1.0 + 1e-12).contains(&v), "overshoot {v}");
            // The sampled step lies at 999.5 rows between the last 0 and first 1.
            let t = (*row as f64 - 999.5) / rate_hz;
            let expected = phi(t / sigma_s);
            assert!((v - expected).abs() < 2e-3, "row {row}: {v} vs {expected}");
        }
        // 10-90 % rise time.
        let crossing = |level: f64| {
            rows.iter()
                .position(|(_, v)| v[0].unwrap() >= level)
                .unwrap()
        };
        let rise_s = (crossing(0.9) - crossing(0.1)) as f64 / rate_hz;
        let expected = RISE_TIME_TIMES_CUTOFF / cutoff_hz;
        assert!(
            (rise_s - expected).abs() <= 1.5 / rate_hz,
            "{rise_s} vs {expected}"
        );
    }

    #[test]
    fn the_gain_at_the_cutoff_is_minus_3_db() {
        let (rate_hz, cutoff_hz) = (500.0, 10.0);
        let mut filter = GaussianFilter::new(Collect::default(), cutoff_hz, rate_hz).unwrap();
        for row in 0..5000u64 {
            let t = row as f64 / rate_hz;
            filter
                .row(
                    row,
                    &[Some((2.0 * std::f64::consts::PI * cutoff_hz * t).sin())],
                )
                .unwrap();
        }
        filter.finish().unwrap();
        let rows = filter.into_inner().0;
        // Amplitude in the middle, away from the ends.
        let peak = rows[1000..4000]
            .iter()
            .map(|(_, v)| v[0].unwrap().abs())
            .fold(0.0, f64::max);
        assert!((peak - 0.5f64.sqrt()).abs() < 2e-3, "gain {peak}");
    }

    #[test]
    fn gaps_stay_gaps_and_constants_stay_constant() {
        let mut filter = GaussianFilter::new(Collect::default(), 2.0, 100.0).unwrap();
        for row in 0..300u64 {
            let value = (!(100..120).contains(&row)).then_some(7.5);
            filter.row(row, &[value]).unwrap();
        }
        filter.finish().unwrap();
        let rows = filter.into_inner().0;
        assert_eq!(rows.len(), 300);
        for (row, values) in rows {
            if (100..120).contains(&row) {
                assert_eq!(values[0], None);
            } else {
                assert!((values[0].unwrap() - 7.5).abs() < 1e-12);
            }
        }
    }
}
