//! Clock offset between two buses (or DAQ units), estimated by
//! cross-correlating a signal each of them sees: the same physical event
//! (the load building up) appears in both, shifted by the offset.
//!
//! Both signals are read onto one uniform grid (linear between samples), the
//! Pearson correlation is computed for every lag in `+-max_lag` on a 5 ms
//! grid, then refined on a 0.25 ms grid around the best lag, and the peak
//! located between grid points by a parabola. The peak's correlation says
//! how alike the two signals are; its curvature gives an approximate
//! standard error `sqrt((1 - r) / (n r k))` (n samples of the slower
//! signal, k the curvature: a time-delay estimate in white noise).

/// Offsets at most this far apart are searched by default, ns.
pub const DEFAULT_MAX_LAG_NS: i64 = 2_000_000_000;
/// Only this much of the overlap is used (memory and time stay bounded), ns.
pub const MAX_WINDOW_NS: i64 = 600_000_000_000;

const COARSE_STEP_NS: i64 = 5_000_000;
const FINE_STEP_NS: i64 = 250_000;

/// An estimated clock offset.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OffsetEstimate {
    /// Signal clock minus reference clock, ns: an event at reference time T
    /// is stamped T + offset by the signal's bus.
    pub offset_ns: f64,
    /// Correlation at the peak (1: identical shapes).
    pub correlation: f64,
    /// Approximate standard error of the offset, ns.
    pub standard_error_ns: f64,
    /// Samples of the slower signal used.
    pub samples: usize,
}

impl OffsetEstimate {
    /// A word for the correlation at the peak.
    pub fn confidence(&self) -> &'static str {
        match self.correlation {
            r if r >= 0.9 => "high",
            r if r >= 0.7 => "medium",
            _ => "low: check that both signals see the same event",
        }
    }
}

/// Reads a sorted series at `t` (linear), `None` outside it.
struct Series<'a> {
    samples: &'a [(i64, f64)],
    cursor: usize,
}

impl<'a> Series<'a> {
    fn at(&mut self, t: i64) -> Option<f64> {
        let s = self.samples;
        if s.is_empty() || t < s[0].0 || t > s[s.len() - 1].0 {
            return None;
        }
        if self.cursor >= s.len() || s[self.cursor].0 > t {
            self.cursor = s.partition_point(|&(ts, _)| ts <= t).saturating_sub(1);
        }
        while self.cursor + 1 < s.len() && s[self.cursor + 1].0 <= t {
            self.cursor += 1;
        }
        let (t0, v0) = s[self.cursor];
        if t0 == t || self.cursor + 1 == s.len() {
            return Some(v0);
        }
        let (t1, v1) = s[self.cursor + 1];
        Some(v0 + (v1 - v0) * (t - t0) as f64 / (t1 - t0) as f64)
    }
}

/// `series` on the grid `start + i * step`, i < n (NaN outside).
fn resample(series: &[(i64, f64)], start: i64, step: i64, n: usize) -> Vec<f64> {
    let mut reader = Series {
        samples: series,
        cursor: 0,
    };
    (0..n)
        .map(|i| reader.at(start + i as i64 * step).unwrap_or(f64::NAN))
        .collect()
}

/// Pearson correlation of x[i + lag] with y[i] over the valid pairs.
fn correlation_at(x: &[f64], y: &[f64], lag: i64) -> Option<f64> {
    let (mut n, mut sx, mut sy, mut sxx, mut syy, mut sxy) = (0usize, 0.0, 0.0, 0.0, 0.0, 0.0);
    for (i, &b) in y.iter().enumerate() {
        let j = i as i64 + lag;
        if j < 0 || j as usize >= x.len() {
            continue;
        }
        let a = x[j as usize];
        if a.is_nan() || b.is_nan() {
            continue;
        }
        n += 1;
        sx += a;
        sy += b;
        sxx += a * a;
        syy += b * b;
        sxy += a * b;
    }
    if n < 3 {
        return None;
    }
    let n = n as f64;
    let cov = sxy - sx * sy / n;
    let vx = sxx - sx * sx / n;
    let vy = syy - sy * sy / n;
    (vx > 0.0 && vy > 0.0).then(|| cov / (vx * vy).sqrt())
}

/// The lag (in steps) with the largest correlation in `lags`.
fn best_lag(x: &[f64], y: &[f64], lags: std::ops::RangeInclusive<i64>) -> Option<(i64, f64)> {
    lags.filter_map(|lag| correlation_at(x, y, lag).map(|r| (lag, r)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
}

/// Estimates `signal`'s clock offset against `reference` (both sorted by
/// time, ns, reference clock unknown to `signal`).
pub fn estimate_offset(
    signal: &[(i64, f64)],
    reference: &[(i64, f64)],
    max_lag_ns: i64,
) -> Result<OffsetEstimate, String> {
    let (Some(&(s0, _)), Some(&(s1, _)), Some(&(r0, _)), Some(&(r1, _))) = (
        signal.first(),
        signal.last(),
        reference.first(),
        reference.last(),
    ) else {
        return Err("a signal has no samples".into());
    };
    // The reference's span, as far as the signal can cover it at some lag.
    let start = r0.max(s0 - max_lag_ns);
    let end = r1.min(s1 + max_lag_ns).min(start + MAX_WINDOW_NS);
    if end - start < 10 * COARSE_STEP_NS {
        return Err("the two signals do not overlap in time".into());
    }
    let lag_steps = max_lag_ns / COARSE_STEP_NS;
    // x covers the reference window widened by the lag range.
    let n_y = ((end - start) / COARSE_STEP_NS) as usize + 1;
    let x_start = start - lag_steps * COARSE_STEP_NS;
    let x = resample(
        signal,
        x_start,
        COARSE_STEP_NS,
        n_y + 2 * lag_steps as usize,
    );
    let y = resample(reference, start, COARSE_STEP_NS, n_y);
    let (coarse, _) = best_lag(&x, &y, 0..=2 * lag_steps).ok_or(
        "a signal does not vary over the overlap: pick signals that change during the test",
    )?;
    let coarse_offset = (coarse - lag_steps) * COARSE_STEP_NS;

    // Refine within +-2 coarse steps.
    let ratio = COARSE_STEP_NS / FINE_STEP_NS;
    let fine_lags = 2 * ratio;
    let n_y = ((end - start) / FINE_STEP_NS) as usize + 1;
    let x_start = start + coarse_offset - fine_lags * FINE_STEP_NS;
    let x = resample(signal, x_start, FINE_STEP_NS, n_y + 2 * fine_lags as usize);
    let y = resample(reference, start, FINE_STEP_NS, n_y);
    let (fine, peak) = best_lag(&x, &y, 0..=2 * fine_lags).ok_or("no correlation peak")?;
    let h = FINE_STEP_NS as f64;
    let mut offset_ns = (coarse_offset + (fine - fine_lags) * FINE_STEP_NS) as f64;
    let mut curvature_per_ns2 = f64::NAN;
    if let (Some(before), Some(after)) = (
        correlation_at(&x, &y, fine - 1),
        correlation_at(&x, &y, fine + 1),
    ) {
        let second = before - 2.0 * peak + after;
        if second < 0.0 {
            offset_ns += h * 0.5 * (before - after) / second;
            curvature_per_ns2 = -second / (h * h);
        }
    }
    let in_window = |series: &[(i64, f64)], shift: i64| {
        series
            .iter()
            .filter(|(t, _)| (start + shift..=end + shift).contains(t))
            .count()
    };
    let samples = in_window(reference, 0).min(in_window(signal, offset_ns as i64));
    let r = peak.clamp(1e-9, 1.0);
    let standard_error_ns = ((1.0 - r) / (samples as f64 * r * curvature_per_ns2)).sqrt();
    Ok(OffsetEstimate {
        offset_ns,
        correlation: peak,
        standard_error_ns: if standard_error_ns.is_finite() {
            standard_error_ns.max(0.0)
        } else {
            f64::INFINITY
        },
        samples,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A load history: idle, ramp up, hold, ramp down (the scenario shape).
    fn load(t_s: f64) -> f64 {
        match t_s {
            t if t < 1.0 => 0.0,
            t if t < 3.0 => (t - 1.0) / 2.0,
            t if t < 8.0 => 1.0,
            t if t < 9.5 => 1.0 - (t - 8.0) / 1.5,
            _ => 0.0,
        }
    }

    fn sampled(
        rng: &mut ChaCha8Rng,
        rate_hz: f64,
        clock_offset_ns: i64,
        gain: f64,
        noise: f64,
    ) -> Vec<(i64, f64)> {
        let period = (1e9 / rate_hz) as i64;
        (0..(12.0 * rate_hz) as i64)
            .map(|i| {
                let t_true = i * period + rng.random_range(0..period / 10);
                let value = gain * load(t_true as f64 * 1e-9) + noise * (rng.random::<f64>() - 0.5);
                (t_true + clock_offset_ns, value)
            })
            .collect()
    }

    #[test]
    fn recovers_a_known_offset_between_differently_scaled_signals() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for true_offset_ms in [-730.0, -12.3, 0.0, 37.6, 1500.0] {
            let offset_ns = (true_offset_ms * 1e6) as i64;
            let reference = sampled(&mut rng, 100.0, 0, 190.0, 1.0);
            let signal = sampled(&mut rng, 500.0, offset_ns, 40.6, 0.2);
            let estimate = estimate_offset(&signal, &reference, DEFAULT_MAX_LAG_NS).unwrap();
            let error_ms = (estimate.offset_ns - offset_ns as f64) / 1e6;
            assert!(estimate.correlation > 0.99, "{estimate:?}");
            assert!(
                error_ms.abs() < 1.0,
                "offset {true_offset_ms} ms estimated {} ms",
                estimate.offset_ns / 1e6
            );
            assert!(estimate.standard_error_ns < 1e6, "{estimate:?}");
        }
    }

    #[test]
    fn a_flat_signal_is_refused_with_a_reason() {
        let flat: Vec<(i64, f64)> = (0..1000).map(|i| (i * 10_000_000, 5.0)).collect();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let moving = sampled(&mut rng, 100.0, 0, 1.0, 0.0);
        let error = estimate_offset(&flat, &moving, DEFAULT_MAX_LAG_NS).unwrap_err();
        assert!(error.contains("does not vary"), "{error}");
        assert!(estimate_offset(&[], &moving, DEFAULT_MAX_LAG_NS).is_err());
    }
}
