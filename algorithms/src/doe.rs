//! Designs of experiments: where to run the model (or the rig) before anything is known.
//!
//! Every design lives in the unit box `[0, 1]^d` (one row per run, one column per
//! parameter); [`scale_to_bounds`] maps a row to physical units and [`scale_to_unit`] back.
//! The designs: maximin Latin hypercube, Sobol points (plain Joe-Kuo or Owen-scrambled),
//! the two-level L12 orthogonal array, full factorial, uniform random, and a design the
//! engineer wrote in a CSV file.

use rand::seq::SliceRandom;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// What went wrong building or reading a design.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DoeError {
    /// A design with no parameter at all was asked for.
    #[error("a design needs at least one dimension (parameter); pass dimensions >= 1")]
    NoDimensions,
    /// More Sobol dimensions than the direction numbers cover.
    #[error(
        "Sobol points: {dimensions} dimensions asked, but {what} covers at most {max}; \
         use fewer dimensions or a Latin hypercube"
    )]
    SobolDimensions {
        /// Dimensions asked for.
        dimensions: usize,
        /// Dimensions supported.
        max: usize,
        /// Which sequence ran out ("the Joe-Kuo table" or "the scrambled sequence").
        what: &'static str,
    },
    /// More scrambled Sobol points than the scrambled generator supports.
    #[error(
        "scrambled Sobol points: {points} asked, at most {max} are supported; \
         ask for fewer points or pass no seed for the unscrambled sequence"
    )]
    SobolPoints {
        /// Points asked for.
        points: usize,
        /// Points supported.
        max: usize,
    },
    /// The L12 array has 11 two-level columns.
    #[error("the L12 orthogonal array holds 1 to 11 two-level factors, {factors} asked; use a full factorial or a Latin hypercube for more")]
    L12Factors {
        /// Factors asked for.
        factors: usize,
    },
    /// A factorial dimension with no level.
    #[error("full factorial: dimension {dimension} (0-based) has 0 levels; give every dimension at least 1 level")]
    ZeroLevels {
        /// The offending dimension.
        dimension: usize,
    },
    /// A factorial too large to hold in memory.
    #[error("full factorial: the levels multiply to more than {max} runs; use fewer levels or a Latin hypercube")]
    TooManyRuns {
        /// The largest design built.
        max: usize,
    },
    /// A problem in a CSV of values (a design, a measured curve), at a
    /// 1-based line.
    #[error("CSV line {line}: {message}")]
    Csv {
        /// 1-based line number in the text.
        line: u64,
        /// What was found and what was expected.
        message: String,
    },
}

/// Largest full factorial built: beyond this the design would not be run anyway.
pub const MAX_FACTORIAL_RUNS: usize = 10_000_000;

/// Rows of Joe-Kuo direction numbers the `sobol` crate ships (new-joe-kuo-6.21201).
pub const MAX_SOBOL_DIMENSIONS: usize = 21_201;

/// Dimensions of the Owen-scrambled sequence (`sobol_burley::NUM_DIMENSIONS`).
pub const MAX_SCRAMBLED_SOBOL_DIMENSIONS: usize = sobol_burley::NUM_DIMENSIONS as usize;

/// Points of the Owen-scrambled sequence (the `sobol_burley` index is 16 bits).
pub const MAX_SCRAMBLED_SOBOL_POINTS: usize = 1 << 16;

/// A maximin Latin hypercube of `n` points in `[0, 1]^dimensions`.
///
/// Each column is a Latin hypercube: exactly one point in each stratum `[k/n, (k+1)/n)`,
/// at a uniformly random position inside it. Among several random hypercubes the one with
/// the largest minimum pairwise distance is kept, then swaps of two points' values within a
/// column (which keep the strata) are accepted whenever they increase that minimum
/// distance. The work is bounded (about 10^8 operations per phase), so large designs
/// get fewer improvement steps, never a long wait. Reproducible for a given seed.
pub fn latin_hypercube(n: usize, dimensions: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    if n < 2 || dimensions == 0 {
        return latin_hypercube_with(&mut rng, n, dimensions);
    }
    // Work per candidate: n^2/2 pairs of `dimensions` coordinates.
    let pair_work = (n.saturating_mul(n) / 2).saturating_mul(dimensions).max(1);
    let candidates = (WORK_BUDGET / pair_work).clamp(1, 16);
    let mut best = latin_hypercube_with(&mut rng, n, dimensions);
    let mut best_distance = min_pairwise_distance(&best);
    for _ in 1..candidates {
        let candidate = latin_hypercube_with(&mut rng, n, dimensions);
        let distance = min_pairwise_distance(&candidate);
        if distance > best_distance {
            best = candidate;
            best_distance = distance;
        }
    }
    // The swap phase keeps an n x n distance matrix; past a few thousand points its memory
    // and the per-step scan cost more than the improvement is worth.
    if n <= MAX_SWAP_POINTS {
        improve_by_swaps(&mut best, &mut rng);
    }
    best
}

/// A plain (not optimised) random Latin hypercube: one point per stratum in every column.
///
/// The baseline [`latin_hypercube`] improves on; reproducible for a given seed.
pub fn random_latin_hypercube(n: usize, dimensions: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    latin_hypercube_with(&mut rng, n, dimensions)
}

/// Bound on the floating-point work of the maximin search.
const WORK_BUDGET: usize = 100_000_000;

/// Largest design the swap phase works on.
const MAX_SWAP_POINTS: usize = 2_000;

fn latin_hypercube_with(rng: &mut ChaCha8Rng, n: usize, dimensions: usize) -> Vec<Vec<f64>> {
    let mut points = vec![vec![0.0; dimensions]; n];
    let mut strata: Vec<usize> = (0..n).collect();
    for column in 0..dimensions {
        strata.shuffle(rng);
        for (point, &stratum) in points.iter_mut().zip(&strata) {
            point[column] = inside_stratum(stratum, n, rng.random());
        }
    }
    points
}

/// The coordinate at `position` in [0, 1) across stratum `stratum` of `n`.
///
/// `(stratum + position) / n` can round a hair outside the stratum as `floor(x * n)` sees
/// it (1/49 * 49 < 1, and a position near 1 can round up to the next stratum or to 1.0), so
/// the value is nudged by single ulps until the stratum it lands in is its own.
fn inside_stratum(stratum: usize, n: usize, position: f64) -> f64 {
    let (target, count) = (stratum as f64, n as f64);
    let mut x = (target + position) / count;
    for _ in 0..8 {
        let landed = (x * count).floor();
        if landed < target {
            // x >= 0 here, so the next representable value up is one bit pattern on.
            x = f64::from_bits(x.to_bits() + 1);
        } else if landed > target && x > 0.0 {
            x = f64::from_bits(x.to_bits() - 1);
        } else {
            break;
        }
    }
    x
}

/// Swap coordinates within columns while that raises the minimum pairwise distance.
fn improve_by_swaps(points: &mut [Vec<f64>], rng: &mut ChaCha8Rng) {
    let n = points.len();
    let dimensions = points.first().map_or(0, Vec::len);
    if n < 3 || dimensions == 0 {
        // With two points every swap gives the same distance.
        return;
    }
    let mut squared = vec![0.0; n * n];
    for i in 0..n {
        for j in (i + 1)..n {
            let d = squared_distance(&points[i], &points[j]);
            squared[i * n + j] = d;
            squared[j * n + i] = d;
        }
    }
    let step_work = n * n / 2 + 2 * n * dimensions;
    let steps = (WORK_BUDGET / step_work).clamp(1, 50 * n * dimensions);
    let (mut worst_i, mut worst_j, mut worst) = closest_pair(&squared, n);
    let mut saved_rows = vec![0.0; 2 * n];
    for _ in 0..steps {
        // Move one point of the closest pair: only its distances can rise.
        let moved = if rng.random_bool(0.5) {
            worst_i
        } else {
            worst_j
        };
        let partner = rng.random_range(0..n - 1);
        let partner = if partner >= moved {
            partner + 1
        } else {
            partner
        };
        let column = rng.random_range(0..dimensions);

        saved_rows[..n].copy_from_slice(&squared[moved * n..(moved + 1) * n]);
        saved_rows[n..].copy_from_slice(&squared[partner * n..(partner + 1) * n]);
        swap_coordinate(points, moved, partner, column);
        for &changed in &[moved, partner] {
            for other in 0..n {
                if other != changed {
                    let d = squared_distance(&points[changed], &points[other]);
                    squared[changed * n + other] = d;
                    squared[other * n + changed] = d;
                }
            }
        }
        let (i, j, candidate) = closest_pair(&squared, n);
        if candidate > worst {
            worst_i = i;
            worst_j = j;
            worst = candidate;
        } else {
            swap_coordinate(points, moved, partner, column);
            for (offset, &changed) in [moved, partner].iter().enumerate() {
                for other in 0..n {
                    let d = saved_rows[offset * n + other];
                    squared[changed * n + other] = d;
                    squared[other * n + changed] = d;
                }
            }
        }
    }
}

fn swap_coordinate(points: &mut [Vec<f64>], a: usize, b: usize, column: usize) {
    let value = points[a][column];
    points[a][column] = points[b][column];
    points[b][column] = value;
}

fn closest_pair(squared: &[f64], n: usize) -> (usize, usize, f64) {
    let mut best = (0, 1, f64::INFINITY);
    for i in 0..n {
        for j in (i + 1)..n {
            let d = squared[i * n + j];
            if d < best.2 {
                best = (i, j, d);
            }
        }
    }
    best
}

fn squared_distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// The smallest Euclidean distance between two points of a design (`+inf` below 2 points).
pub fn min_pairwise_distance(points: &[Vec<f64>]) -> f64 {
    let mut smallest = f64::INFINITY;
    for (i, a) in points.iter().enumerate() {
        for b in &points[i + 1..] {
            smallest = smallest.min(squared_distance(a, b));
        }
    }
    smallest.sqrt()
}

/// The first `n` points of the Sobol sequence in `[0, 1]^dimensions`.
///
/// Without a seed: the plain sequence with Joe & Kuo's `new-joe-kuo-6.21201` direction
/// numbers in Gray-code order, starting at the origin (the same points as
/// `scipy.stats.qmc.Sobol(d, scramble=False)`), up to 21 201 dimensions.
///
/// With a seed: an Owen-scrambled, shuffled Sobol sequence (Burley 2020, via the
/// `sobol_burley` crate): the points keep the net structure but are randomised, so they
/// avoid the origin and the corners and differ between seeds. The crate's seed is 32 bits:
/// the two halves of `seed` are combined by XOR. Up to 256 dimensions and 65 536 points;
/// its values have single precision (steps of 2^-24), ample for a design.
///
/// Take `n` a power of two for the best balance.
pub fn sobol_points(
    n: usize,
    dimensions: usize,
    seed: Option<u64>,
) -> Result<Vec<Vec<f64>>, DoeError> {
    if dimensions == 0 {
        return Err(DoeError::NoDimensions);
    }
    match seed {
        None => plain_sobol(n, dimensions),
        Some(seed) => scrambled_sobol(n, dimensions, seed),
    }
}

fn plain_sobol(n: usize, dimensions: usize) -> Result<Vec<Vec<f64>>, DoeError> {
    use sobol::params::JoeKuoD6;
    // The smallest table that covers the dimensions: each is parsed from gzip on load.
    let params = if dimensions <= 100 {
        JoeKuoD6::minimal()
    } else if dimensions <= 1_000 {
        JoeKuoD6::standard()
    } else if dimensions <= MAX_SOBOL_DIMENSIONS {
        JoeKuoD6::extended()
    } else {
        return Err(DoeError::SobolDimensions {
            dimensions,
            max: MAX_SOBOL_DIMENSIONS,
            what: "the Joe-Kuo table",
        });
    };
    Ok(sobol::Sobol::<f64>::new(dimensions, &params)
        .take(n)
        .collect())
}

fn scrambled_sobol(n: usize, dimensions: usize, seed: u64) -> Result<Vec<Vec<f64>>, DoeError> {
    if dimensions > MAX_SCRAMBLED_SOBOL_DIMENSIONS {
        return Err(DoeError::SobolDimensions {
            dimensions,
            max: MAX_SCRAMBLED_SOBOL_DIMENSIONS,
            what: "the scrambled sequence",
        });
    }
    if n > MAX_SCRAMBLED_SOBOL_POINTS {
        return Err(DoeError::SobolPoints {
            points: n,
            max: MAX_SCRAMBLED_SOBOL_POINTS,
        });
    }
    let folded_seed = (seed ^ (seed >> 32)) as u32;
    Ok((0..n as u32)
        .map(|index| {
            (0..dimensions as u32)
                .map(|dimension| f64::from(sobol_burley::sample(index, dimension, folded_seed)))
                .collect()
        })
        .collect())
}

/// The standard Taguchi L12 two-level orthogonal array (a 12-run Plackett-Burman design):
/// 12 runs, 11 columns, levels 1 and 2. Every pair of columns holds each of the four level
/// combinations exactly three times.
const L12: [[u8; 11]; 12] = [
    [1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1],
    [1, 1, 1, 1, 1, 2, 2, 2, 2, 2, 2],
    [1, 1, 2, 2, 2, 1, 1, 1, 2, 2, 2],
    [1, 2, 1, 2, 2, 1, 2, 2, 1, 1, 2],
    [1, 2, 2, 1, 2, 2, 1, 2, 1, 2, 1],
    [1, 2, 2, 2, 1, 2, 2, 1, 2, 1, 1],
    [2, 1, 2, 2, 1, 1, 2, 2, 1, 2, 1],
    [2, 1, 2, 1, 2, 2, 2, 1, 1, 1, 2],
    [2, 1, 1, 2, 2, 2, 1, 2, 2, 1, 1],
    [2, 2, 2, 1, 1, 1, 1, 2, 2, 1, 2],
    [2, 2, 1, 2, 1, 2, 1, 1, 1, 2, 2],
    [2, 2, 1, 1, 2, 1, 2, 1, 2, 2, 1],
];

/// The first `factors` columns of the standard L12 array: 12 runs of levels 1/2.
///
/// With 8 factors these are the 12 runs of the published excavator calibration.
pub fn orthogonal_array_l12(factors: usize) -> Result<Vec<Vec<u8>>, DoeError> {
    if !(1..=11).contains(&factors) {
        return Err(DoeError::L12Factors { factors });
    }
    Ok(L12.iter().map(|row| row[..factors].to_vec()).collect())
}

/// Two-level runs into the unit box: level 1 -> 0.0 (low), level 2 -> 1.0 (high).
///
/// The function cannot fail, so other codes are read by the same threshold: 1 or less is
/// low, 2 or more is high.
pub fn two_level_to_unit(levels: &[Vec<u8>]) -> Vec<Vec<f64>> {
    levels
        .iter()
        .map(|run| {
            run.iter()
                .map(|&level| if level > 1 { 1.0 } else { 0.0 })
                .collect()
        })
        .collect()
}

/// Every combination of levels: `levels_per_dimension[k]` evenly spaced values from 0 to 1
/// in dimension `k` (a single level sits at 0.5). The first dimension varies slowest, the
/// last fastest (the order of nested loops).
pub fn full_factorial(levels_per_dimension: &[usize]) -> Result<Vec<Vec<f64>>, DoeError> {
    if levels_per_dimension.is_empty() {
        return Err(DoeError::NoDimensions);
    }
    let mut runs: usize = 1;
    for (dimension, &levels) in levels_per_dimension.iter().enumerate() {
        if levels == 0 {
            return Err(DoeError::ZeroLevels { dimension });
        }
        runs = runs
            .checked_mul(levels)
            .filter(|&runs| runs <= MAX_FACTORIAL_RUNS)
            .ok_or(DoeError::TooManyRuns {
                max: MAX_FACTORIAL_RUNS,
            })?;
    }
    let level_value = |level: usize, levels: usize| {
        if levels == 1 {
            0.5
        } else {
            level as f64 / (levels - 1) as f64
        }
    };
    let mut design = Vec::with_capacity(runs);
    for run in 0..runs {
        let mut point = vec![0.0; levels_per_dimension.len()];
        let mut remainder = run;
        for (coordinate, &levels) in point.iter_mut().zip(levels_per_dimension).rev() {
            *coordinate = level_value(remainder % levels, levels);
            remainder /= levels;
        }
        design.push(point);
    }
    Ok(design)
}

/// `n` independent uniform points in `[0, 1)^dimensions`; reproducible for a given seed.
pub fn random_uniform(n: usize, dimensions: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| (0..dimensions).map(|_| rng.random::<f64>()).collect())
        .collect()
}

/// A unit-box point in physical units: `lower + u * (upper - lower)` per coordinate.
///
/// `unit` and `bounds` should have the same length; the result has the shorter length.
pub fn scale_to_bounds(unit: &[f64], bounds: &[(f64, f64)]) -> Vec<f64> {
    unit.iter()
        .zip(bounds)
        .map(|(&u, &(lower, upper))| lower + u * (upper - lower))
        .collect()
}

/// A physical point into the unit box: `(x - lower) / (upper - lower)` per coordinate.
///
/// A fixed parameter (`lower == upper`) maps to 0.5, the middle of its empty range, as a
/// single factorial level does. The result has the shorter of the two lengths.
pub fn scale_to_unit(point: &[f64], bounds: &[(f64, f64)]) -> Vec<f64> {
    point
        .iter()
        .zip(bounds)
        .map(|(&x, &(lower, upper))| {
            let width = upper - lower;
            if width == 0.0 {
                0.5
            } else {
                (x - lower) / width
            }
        })
        .collect()
}

/// A design written by hand: CSV text with a header row, the columns `names` picked out in
/// that order (so the result's columns follow `names`, not the file).
///
/// Columns not named are ignored, surrounding spaces in names and cells are trimmed and a
/// UTF-8 byte-order mark is skipped. A named column missing from the header, a header that
/// names a column twice, a row too short to hold a named column, and a cell that is not a
/// finite number are errors that carry the 1-based line number. Values are returned as
/// written (physical units); pass them through [`scale_to_unit`] if the unit box is wanted.
pub fn read_design_csv(text: &str, names: &[&str]) -> Result<Vec<Vec<f64>>, DoeError> {
    read_csv_columns(text, names, "run")
}

/// The columns `names` of CSV text with a header row, as
/// [`read_design_csv`] reads them; `row` names what a row is (a "run" of a
/// design, a "point" of a curve) in the error of a file without one.
pub fn read_csv_columns(text: &str, names: &[&str], row: &str) -> Result<Vec<Vec<f64>>, DoeError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    if names.is_empty() {
        return Err(DoeError::Csv {
            line: 1,
            message: "no column names were asked for; name the parameters to read".into(),
        });
    }
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let header = reader
        .headers()
        .map_err(|error| csv_error(&error, 1))?
        .clone();
    if header.iter().all(str::is_empty) {
        return Err(DoeError::Csv {
            line: 1,
            message: format!(
                "expected a header row naming the columns ({}), found an empty line",
                names.join(", ")
            ),
        });
    }
    let mut columns = Vec::with_capacity(names.len());
    for name in names {
        let mut found = header.iter().enumerate().filter(|(_, h)| h == name);
        match (found.next(), found.next()) {
            (Some((index, _)), None) => columns.push(index),
            (Some(_), Some(_)) => {
                return Err(DoeError::Csv {
                    line: 1,
                    message: format!(
                        "the header names column '{name}' more than once; rename one of them"
                    ),
                })
            }
            (None, _) => {
                return Err(DoeError::Csv {
                    line: 1,
                    message: format!(
                    "the header has no column '{name}' (it has: {}); add it or fix its spelling",
                    header.iter().collect::<Vec<_>>().join(", ")
                ),
                })
            }
        }
    }
    let mut design = Vec::new();
    for record in reader.records() {
        let record = record.map_err(|error| csv_error(&error, 0))?;
        let line = record.position().map_or(0, csv::Position::line);
        // A line of only separators or spaces is a blank line, not a run.
        if record.iter().all(str::is_empty) {
            continue;
        }
        let mut point = Vec::with_capacity(columns.len());
        for (&column, name) in columns.iter().zip(names) {
            let cell = record.get(column).ok_or_else(|| DoeError::Csv {
                line,
                message: format!(
                    "expected a value for '{name}' in field {}, the line has only {} fields",
                    column + 1,
                    record.len()
                ),
            })?;
            let value = cell
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| DoeError::Csv {
                    line,
                    message: format!("'{name}' must be a finite number, found '{cell}'"),
                })?;
            point.push(value);
        }
        design.push(point);
    }
    if design.is_empty() {
        return Err(DoeError::Csv {
            line: 2,
            message: format!("a header but no rows of values; add one row per {row}"),
        });
    }
    Ok(design)
}

fn csv_error(error: &csv::Error, fallback_line: u64) -> DoeError {
    let line = error.position().map_or(fallback_line, csv::Position::line);
    DoeError::Csv {
        line,
        message: format!("cannot read the CSV ({error}); expected comma-separated text"),
    }
}
