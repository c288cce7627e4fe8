//! One signal as the page draws it: the smallest and largest value of every
//! bucket of fixed length, and a per-pixel fold of those buckets.
//!
//! Min/max per pixel keeps every spike a line would show and costs two
//! points per pixel whatever the sample rate. Buckets are kept in a ring:
//! a live view keeps its window (memory fixed by the window, not by the
//! session), a recorded session keeps all of it.

use std::collections::VecDeque;

/// The shortest bucket: 10 ms, 1,200 of them under a minute's plot.
pub const BUCKET_NS: i64 = 10_000_000;
/// A series over a whole session holds at most this many buckets (each
/// [`BUCKET_NS`] or longer): about 1.5 MB per sensor, whatever its length.
pub const WHOLE_SPAN_BUCKETS: i64 = 1 << 17;

/// The smallest and largest value of one stretch of time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MinMax {
    pub min: f32,
    pub max: f32,
}

impl MinMax {
    /// Plots need no more than single precision; it halves the memory.
    fn of(value: f64) -> Self {
        MinMax {
            min: value as f32,
            max: value as f32,
        }
    }

    fn merge(&mut self, other: MinMax) {
        self.min = self.min.min(other.min);
        self.max = self.max.max(other.max);
    }
}

/// One pixel column of a plot: its time span's start and its extremes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Column {
    /// Start of the column, ns on the session's clock.
    pub start_ns: i64,
    pub extremes: MinMax,
}

/// A signal as consecutive buckets of `bucket_ns`, the oldest dropped past
/// `capacity` buckets.
#[derive(Clone, Debug)]
pub struct MinMaxSeries {
    bucket_ns: i64,
    capacity: usize,
    /// Past the capacity: buckets twice as long (the whole span kept), or
    /// the oldest dropped (a window).
    coarsens: bool,
    /// Index (time / bucket_ns) of `buckets[0]`.
    first_index: i64,
    /// `None`: no sample in that bucket (a gap, drawn as one).
    buckets: VecDeque<Option<MinMax>>,
}

impl MinMaxSeries {
    pub fn new(bucket_ns: i64, capacity: usize) -> Self {
        assert!(bucket_ns > 0 && capacity > 0);
        MinMaxSeries {
            bucket_ns,
            capacity,
            coarsens: false,
            first_index: 0,
            buckets: VecDeque::new(),
        }
    }

    /// A series that keeps everything from its first sample on: past
    /// `capacity` buckets, each two neighbours become one twice as long.
    pub fn whole(bucket_ns: i64, capacity: usize) -> Self {
        MinMaxSeries {
            coarsens: true,
            ..MinMaxSeries::new(bucket_ns, capacity.max(2))
        }
    }

    /// Coarsens until the buckets are `bucket_ns` long (a whole-span
    /// series whose buckets are a power-of-two fraction of it).
    pub fn coarsen_to(&mut self, bucket_ns: i64) {
        while self.bucket_ns < bucket_ns {
            self.coarsen();
        }
    }

    fn coarsen(&mut self) {
        let first = self.first_index.div_euclid(2);
        let mut merged: VecDeque<Option<MinMax>> = VecDeque::new();
        for (k, bucket) in self.buckets.iter().enumerate() {
            let slot = ((self.first_index + k as i64).div_euclid(2) - first) as usize;
            if slot == merged.len() {
                merged.push_back(None);
            }
            if let Some(b) = bucket {
                match &mut merged[slot] {
                    Some(m) => m.merge(*b),
                    empty => *empty = Some(*b),
                }
            }
        }
        self.first_index = first;
        self.buckets = merged;
        self.bucket_ns *= 2;
    }

    pub fn bucket_ns(&self) -> i64 {
        self.bucket_ns
    }

    /// The index of the first bucket and every bucket, oldest first.
    pub fn buckets(&self) -> (i64, impl ExactSizeIterator<Item = &Option<MinMax>>) {
        (self.first_index, self.buckets.iter())
    }

    /// A series from [`MinMaxSeries::buckets`]'s parts.
    pub fn from_buckets(bucket_ns: i64, first_index: i64, buckets: Vec<Option<MinMax>>) -> Self {
        MinMaxSeries {
            bucket_ns,
            capacity: buckets.len().max(1),
            coarsens: false,
            first_index,
            buckets: buckets.into(),
        }
    }

    /// The span held, `[start, end)` ns, if any sample came.
    pub fn span_ns(&self) -> Option<(i64, i64)> {
        (!self.buckets.is_empty()).then(|| {
            (
                self.first_index * self.bucket_ns,
                (self.first_index + self.buckets.len() as i64) * self.bucket_ns,
            )
        })
    }

    /// Adds one sample. A sample older than the ring's start is dropped
    /// (it would be off the window); a gap of empty buckets is bounded by the
    /// capacity.
    pub fn push(&mut self, time_ns: i64, value: f64) {
        if !value.is_finite() {
            return;
        }
        let index = time_ns.div_euclid(self.bucket_ns);
        if self.buckets.is_empty() {
            self.first_index = index;
            self.buckets.push_back(Some(MinMax::of(value)));
            return;
        }
        if index < self.first_index {
            return;
        }
        if self.coarsens {
            while time_ns.div_euclid(self.bucket_ns) - self.first_index >= self.capacity as i64 {
                self.coarsen();
            }
            return self.push_within(time_ns.div_euclid(self.bucket_ns), value);
        }
        let last = self.first_index + self.buckets.len() as i64 - 1;
        if index > last {
            let missing = (index - last) as usize;
            if missing >= self.capacity {
                // Everything held is older than the window: start again.
                self.buckets.clear();
                self.first_index = index;
                self.buckets.push_back(Some(MinMax::of(value)));
                return;
            } else {
                self.buckets.extend(std::iter::repeat_n(None, missing));
            }
        }
        self.push_within(index, value);
        while self.buckets.len() > self.capacity {
            self.buckets.pop_front();
            self.first_index += 1;
        }
    }

    /// Adds a sample to bucket `index`, at or after the first.
    fn push_within(&mut self, index: i64, value: f64) {
        let slot = (index - self.first_index) as usize;
        if slot >= self.buckets.len() {
            self.buckets.resize(slot + 1, None);
        }
        match &mut self.buckets[slot] {
            Some(extremes) => extremes.merge(MinMax::of(value)),
            empty => *empty = Some(MinMax::of(value)),
        }
    }

    /// Folds the buckets of `[from_ns, to_ns)` into at most `columns` columns
    /// of whole buckets (a column's edges are bucket edges, so a column is
    /// exactly the samples of its buckets). Columns without a sample are left
    /// out: the page draws a gap there.
    pub fn columns(&self, from_ns: i64, to_ns: i64, columns: usize) -> Vec<Column> {
        let Some((start, end)) = self.span_ns() else {
            return Vec::new();
        };
        let from = from_ns.max(start).div_euclid(self.bucket_ns);
        let to = (to_ns.min(end) + self.bucket_ns - 1).div_euclid(self.bucket_ns);
        if to <= from || columns == 0 {
            return Vec::new();
        }
        let buckets = (to - from) as usize;
        let per_column = buckets.div_ceil(columns);
        let mut out = Vec::with_capacity(buckets.div_ceil(per_column));
        let mut index = from;
        while index < to {
            let stop = (index + per_column as i64).min(to);
            let mut extremes: Option<MinMax> = None;
            for i in index..stop {
                if let Some(bucket) = self.buckets[(i - self.first_index) as usize] {
                    match &mut extremes {
                        Some(e) => e.merge(bucket),
                        None => extremes = Some(bucket),
                    }
                }
            }
            if let Some(extremes) = extremes {
                out.push(Column {
                    start_ns: index * self.bucket_ns,
                    extremes,
                });
            }
            index = stop;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Every column equals the brute-force min and max of the raw
        /// samples in its time span, and no sample in the range is missed.
        #[test]
        fn columns_equal_brute_force(
            samples in proptest::collection::vec((0i64..5_000_000_000, -1e3f64..1e3), 1..400),
            bucket_ms in 1i64..50,
            from_ms in 0i64..5_000,
            width_ms in 1i64..6_000,
            columns in 1usize..300,
        ) {
            let bucket_ns = bucket_ms * 1_000_000;
            let mut series = MinMaxSeries::new(bucket_ns, usize::MAX / 2);
            let mut sorted = samples.clone();
            sorted.sort_by_key(|s| s.0);
            for &(t, v) in &sorted {
                series.push(t, v);
            }
            let (from, to) = (from_ms * 1_000_000, (from_ms + width_ms) * 1_000_000);
            let out = series.columns(from, to, columns);
            prop_assert!(out.len() <= columns);
            let mut covered = 0;
            for (k, column) in out.iter().enumerate() {
                let next = out.get(k + 1).map_or(i64::MAX, |c| c.start_ns);
                // The column's own buckets end before the next column starts.
                let inside: Vec<f32> = sorted
                    .iter()
                    .filter(|(t, _)| *t >= column.start_ns && *t < next
                        && t.div_euclid(bucket_ns) < (to + bucket_ns - 1).div_euclid(bucket_ns))
                    .map(|s| s.1 as f32)
                    .collect();
                prop_assert!(!inside.is_empty());
                let min = inside.iter().cloned().fold(f32::INFINITY, f32::min);
                let max = inside.iter().cloned().fold(f32::NEG_INFINITY, f32::max);
                prop_assert_eq!(column.extremes, MinMax { min, max });
                covered += inside.len();
            }
            // Every sample whose bucket overlaps [from, to) is in a column.
            let expected = sorted
                .iter()
                .filter(|(t, _)| {
                    let b = t.div_euclid(bucket_ns);
                    b >= from.div_euclid(bucket_ns) && b < (to + bucket_ns - 1).div_euclid(bucket_ns)
                })
                .count();
            prop_assert_eq!(covered, expected);
        }
    }

    proptest! {
        /// A whole-span series that coarsened holds, in each of its
        /// buckets, exactly the extremes of the samples in its span.
        #[test]
        fn coarsened_buckets_equal_brute_force(
            samples in proptest::collection::vec((0i64..100_000, -1e3f64..1e3), 1..300),
            capacity in 2usize..40,
        ) {
            let mut sorted = samples.clone();
            sorted.sort_by_key(|s| s.0);
            let mut series = MinMaxSeries::whole(10, capacity);
            for &(t, v) in &sorted {
                series.push(t, v);
            }
            let (first, buckets) = series.buckets();
            prop_assert!(buckets.len() <= capacity);
            let width = series.bucket_ns();
            let (first, buckets): (i64, Vec<Option<MinMax>>) = (first, buckets.copied().collect());
            let mut seen = 0;
            for (k, bucket) in buckets.iter().enumerate() {
                let start = (first + k as i64) * width;
                let inside: Vec<f32> = sorted
                    .iter()
                    .filter(|(t, _)| *t >= start && *t < start + width)
                    .map(|s| s.1 as f32)
                    .collect();
                seen += inside.len();
                let expected = (!inside.is_empty()).then(|| MinMax {
                    min: inside.iter().cloned().fold(f32::INFINITY, f32::min),
                    max: inside.iter().cloned().fold(f32::NEG_INFINITY, f32::max),
                });
                prop_assert_eq!(*bucket, expected);
            }
            prop_assert_eq!(seen, sorted.len());
        }
    }

    #[test]
    fn the_ring_keeps_the_window_and_a_long_gap_restarts_it() {
        let mut series = MinMaxSeries::new(10, 100);
        for t in 0..5_000 {
            series.push(t, t as f64);
        }
        assert_eq!(series.span_ns(), Some((4_000, 5_000)));
        let all = series.columns(0, 10_000, 1);
        assert_eq!(
            all,
            vec![Column {
                start_ns: 4_000,
                extremes: MinMax {
                    min: 4_000.0,
                    max: 4_999.0
                }
            }]
        );
        series.push(1_000_000, 1.0);
        assert_eq!(series.span_ns(), Some((1_000_000, 1_000_010)));
        // Out of the window, NaN: ignored.
        series.push(0, 7.0);
        series.push(1_000_001, f64::NAN);
        assert_eq!(series.columns(0, i64::MAX / 2, 10).len(), 1);
    }
}
