//! Material properties of a tensile test from its force-displacement
//! curve: Young's modulus, the 0.2 % offset yield strength, the UTS, the
//! plastic flow curve an FE model needs, and the bounds of the post-UTS
//! slope `m` a calibration searches (`acq tensile-props`).
//!
//! # Input
//!
//! A CSV whose header names a `DISPLACEMENT` (mm) and a `FORCE` (kN)
//! column (by name, case-insensitive, units in brackets allowed and
//! checked: `DISPLACEMENT [mm]`, `FORCE [kN]` or `FORCE [N]`); other
//! columns are ignored, lines starting with `#` and blank lines skipped.
//! Both the test files in data/tensile/ and the curves `acq extract`
//! writes ([`super::tensile`]) read as they are. The curve must be zeroed
//! (start at the origin), as both are.
//!
//! # Method
//!
//! Engineering strain `e = u / L` with `L` the length the displacement is
//! measured over (default 12.5 mm: the published data are half the 25 mm
//! gauge of an axisymmetric half model), engineering stress `s = F / A`
//! with `A = pi d^2 / 4` (default d = 4 mm). True strain `ln(1 + e)`, true
//! stress `s (1 + e)`.
//!
//! 1. **UTS**: the measured point of maximum force (the first if the
//!    maximum repeats); nothing is interpolated or smoothed.
//! 2. **Young's modulus E**: least-squares line *through the origin* (the
//!    curve is zeroed there, and with the 2-8 points these tests have in
//!    the elastic range an intercept is poorly determined) of engineering
//!    stress on engineering strain, over the loaded points from the start
//!    up to the first point whose stress exceeds the limit
//!    `min(60 % of the UTS stress, 80 % of Rp0.2)`. The limit keeps the fit
//!    below the proportional limit: 60 % of the UTS is below yield for
//!    steels like P91 (yield/UTS about 0.75); the 80 % of Rp0.2 cap
//!    protects materials with a low yield ratio. As Rp0.2 depends on E,
//!    the two are iterated until the fitted points no longer change (at
//!    most 10 rounds; it takes 1-2). With fewer than 2 loaded points below
//!    the limit, the first 2 loaded points are used and a note says so.
//!    The points used, the limit and the rms residual are reported.
//! 3. **Yield**: the 0.2 % offset yield strength Rp0.2 (ISO 6892-1): where
//!    the curve, read linearly between measured points, first falls below
//!    the line `s = E (e - 0.002)`. It must come before the UTS.
//! 4. **Flow curve** (true stress vs plastic strain, the table an FE
//!    plasticity model takes): plastic strain `ln(1 + e) - s (1 + e) / E`,
//!    *not shifted*. The first row (plastic strain 0) is the onset of
//!    plasticity: where the plastic strain turns positive for the last
//!    time before Rp0.2 (read linearly between the two points around the
//!    crossing; points of the elastic range that scatter above zero are
//!    ignored). Then every measured point after it up to and including the
//!    UTS. Unshifted, a model stretched uniformly with this table and E
//!    retraces the measured curve up to the UTS; shifting the table to
//!    start at Rp0.2 (the other common convention) would put the model's
//!    curve 0.2 % strain (0.025 mm here) ahead of the test and its knee
//!    several per cent above it. Points whose plastic strain does not
//!    increase are dropped (strictly increasing is what FE codes require)
//!    and counted.
//! 5. **Post-UTS slope m**: least-squares lines (with intercept) of true
//!    stress on true strain through the last 2, 3, 4, 5 and 6 measured
//!    points up to and including the UTS. Lower bound 0; upper bound the
//!    largest of these slopes rounded *up* to a multiple of 50 MPa (the
//!    published code's `np.arange(0, max_slope + 50, 50)` ends there too).
//!
//! # Results on the published tests, and how they compare
//!
//! | | Dataset 1 (20 C) | Dataset 3 (500 C) |
//! |---|---|---|
//! | E, this method | 232,738 MPa (4 points <= 350 MPa, rms 7 MPa) | 187,202 MPa (8 points <= 299 MPa, rms 20 MPa) |
//! | E, published run | 207,011 MPa | 155,984 MPa |
//! | Rp0.2, this method | 438.0 MPa | 419.5 MPa |
//! | yield, published run | 403.7 MPa | 391.2 MPa |
//! | UTS | 7.4597 kN at 1.32067 mm, 593.6 MPa | 6.2530 kN at 0.53542 mm, 497.6 MPa |
//! | m fits (2..6 points) | 753.4, 799.0, 703.0, 674.2, 703.7 | 623.9, 677.7, 726.0, 747.6, 755.2 |
//! | m bounds | 0..800 MPa (published 800) | 0..800 MPa (published 800) |
//! | flow curve rows (none dropped) | 129 | 34 |
//!
//! Our E is 12 % (Dataset 1) and 20 % (Dataset 3) above the published
//! values. The published E came from a linear fit (with intercept, on the
//! true curve re-sampled linearly every 1e-4 strain) up to a point picked
//! where a Savitzky-Golay second derivative is nearest zero, the filter
//! window chosen by a score; its yield is the stress at that point, not an
//! offset yield. Judging by those yields
//! (403.7 and 391.2 MPa) that fit reaches into the knee of the curve (for
//! Dataset 1 the points at 390 and 406 MPa have secant moduli of 209 and
//! 177 GPa), which lowers E. Handbook values for P91 are roughly 215-220
//! GPa at 20 C and 180-190 GPa at 500 C; ours are closer to those, but with
//! 4-8 points in the elastic range scattering 7-20 MPa rms about the line,
//! neither is an accurate modulus: calibrate against the force-displacement
//! curve, not against E. Rp0.2 barely depends on E (438.0-440.4 MPa for
//! Dataset 1 over fit limits of 50-70 % UTS) and lies 34 and 28 MPa above
//! the published yields, which mark the onset of the knee rather than
//! 0.2 % plastic strain. The published flow table started at the measured
//! point nearest its yield stress; ours starts where the plastic strain
//! turns positive (true stress 348.7 MPa for Dataset 1, 320.5 MPa for
//! Dataset 3: the knee begins just above the points E is fitted to).

use std::path::Path;

use acq_error::{AcqError, Result};
use serde::Serialize;

/// Offset of the offset yield strength (0.2 %).
pub const YIELD_OFFSET_STRAIN: f64 = 0.002;
/// The elastic fit uses points up to this fraction of the UTS stress...
pub const ELASTIC_LIMIT_UTS_FRACTION: f64 = 0.6;
/// ... and of Rp0.2, whichever is lower.
pub const ELASTIC_LIMIT_YIELD_FRACTION: f64 = 0.8;
/// Post-UTS slope fits use the last 2..=this many points.
pub const SLOPE_FIT_MAX_POINTS: usize = 6;
/// The slope's upper bound is rounded up to a multiple of this, in MPa.
pub const SLOPE_BOUND_STEP_MPA: f64 = 50.0;
const MAX_ELASTIC_ROUNDS: usize = 10;

/// The specimen: its diameter and the length the displacement is measured
/// over.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SpecimenGeometry {
    pub diameter_mm: f64,
    /// Engineering strain = displacement / this (12.5 mm: half the 25 mm
    /// gauge, as in the published half-model data).
    pub strain_length_mm: f64,
}

impl Default for SpecimenGeometry {
    fn default() -> Self {
        SpecimenGeometry {
            diameter_mm: 4.0,
            strain_length_mm: 12.5,
        }
    }
}

impl SpecimenGeometry {
    pub fn area_mm2(&self) -> f64 {
        std::f64::consts::PI * self.diameter_mm * self.diameter_mm / 4.0
    }
}

/// One measured point of the test curve.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TestPoint {
    pub displacement_mm: f64,
    pub force_kn: f64,
}

/// Everything `acq tensile-props` reports. Point indices count the data
/// rows of the test file from 0 (the origin row in the published files).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TensileProperties {
    pub diameter_mm: f64,
    pub strain_length_mm: f64,
    pub area_mm2: f64,
    pub test_points: usize,
    pub youngs_modulus_mpa: f64,
    pub elastic_fit: ElasticFit,
    pub yield_point: YieldPoint,
    pub uts: Uts,
    pub flow_curve: FlowCurve,
    pub post_uts_slope: PostUtsSlope,
    pub notes: Vec<String>,
}

/// How E was fitted.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ElasticFit {
    pub method: String,
    /// Indices of the points in the fit (the origin adds nothing to a fit
    /// through it and is not counted).
    pub first_point: usize,
    pub last_point: usize,
    pub points_used: usize,
    /// Stress limit of the fitted points.
    pub stress_limit_mpa: f64,
    pub max_stress_used_mpa: f64,
    pub rms_residual_mpa: f64,
}

/// The 0.2 % offset yield point, read linearly between two measured points.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct YieldPoint {
    pub method: String,
    pub stress_mpa: f64,
    pub strain: f64,
    pub displacement_mm: f64,
    pub force_kn: f64,
    pub true_stress_mpa: f64,
    pub true_strain: f64,
    /// The yield point lies between this point and the next.
    pub after_point: usize,
}

/// The maximum force and its point.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Uts {
    pub point: usize,
    pub force_kn: f64,
    pub displacement_mm: f64,
    pub engineering_stress_mpa: f64,
    pub engineering_strain: f64,
    pub true_stress_mpa: f64,
    pub true_strain: f64,
}

/// One row of the flow curve.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FlowPoint {
    pub plastic_strain: f64,
    pub true_stress_mpa: f64,
}

/// True stress vs plastic strain from the onset of plasticity to the UTS.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FlowCurve {
    pub points: Vec<FlowPoint>,
    /// The measured point after which the plastic strain stays positive
    /// (the first row lies between it and the next).
    pub onset_after_point: usize,
    /// Engineering strain at the first row.
    pub onset_strain: f64,
    pub dropped_non_increasing: usize,
    /// Measured points pooled because their true stress did not rise (noise
    /// on a flat stretch of the curve): see [`pool_to_increasing_stress`].
    pub pooled_for_increasing_stress: usize,
}

/// One straight-line fit before the UTS.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SlopeFit {
    pub points: usize,
    pub slope_mpa: f64,
}

/// The range a calibration searches for the post-UTS slope m.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PostUtsSlope {
    pub fits: Vec<SlopeFit>,
    pub max_slope_mpa: f64,
    pub lower_bound_mpa: f64,
    pub upper_bound_mpa: f64,
}

/// Reads a test CSV; malformed content is [`AcqError::Malformed`] with
/// `file:line`, a file that cannot be opened [`AcqError::Config`].
pub fn read_test_csv(path: &Path) -> Result<Vec<TestPoint>> {
    let text = acq_io::input::read_text(path).map_err(|e| AcqError::open(path, e))?;
    acq_io::input::note_input(path);
    parse_test_csv(&text, &path.display().to_string()).map_err(AcqError::Malformed)
}

/// Column of a header field, if it is `name` (with an optional unit in
/// brackets or parentheses).
fn column_unit<'a>(field: &'a str, name: &str) -> Option<&'a str> {
    let field = field.trim().trim_matches('"').trim();
    let (head, unit) = match field.find(['[', '(']) {
        Some(open) => {
            let unit = field[open + 1..].trim_end_matches([']', ')']).trim();
            (field[..open].trim(), unit)
        }
        None => (field, ""),
    };
    head.eq_ignore_ascii_case(name).then_some(unit)
}

/// Parses test CSV text; `name` prefixes every error (`name:line: ...`).
pub fn parse_test_csv(text: &str, name: &str) -> std::result::Result<Vec<TestPoint>, String> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, line)| (i + 1, line.trim()))
        .filter(|(_, line)| !line.is_empty() && !line.starts_with('#'));
    let Some((header_line, header)) = lines.next() else {
        return Err(format!(
            "{name}: no header line; expected one naming DISPLACEMENT [mm] and FORCE [kN] columns"
        ));
    };
    let fields: Vec<&str> = header.split(',').collect();
    let find = |column: &str, units: &[(&str, f64)]| -> std::result::Result<(usize, f64), String> {
        let mut found = None;
        for (index, field) in fields.iter().enumerate() {
            let Some(unit) = column_unit(field, column) else {
                continue;
            };
            if found.is_some() {
                return Err(format!(
                    "{name}:{header_line}: two {column} columns in the header"
                ));
            }
            let scale = if unit.is_empty() {
                units[0].1
            } else {
                units
                    .iter()
                    .find(|(u, _)| u.eq_ignore_ascii_case(unit))
                    .map(|&(_, scale)| scale)
                    .ok_or_else(|| {
                        let expected: Vec<String> =
                            units.iter().map(|(u, _)| format!("[{u}]")).collect();
                        format!(
                            "{name}:{header_line}: column {column} is in [{unit}]; expected {}",
                            expected.join(" or ")
                        )
                    })?
            };
            found = Some((index, scale));
        }
        found.ok_or_else(|| {
            format!(
                "{name}:{header_line}: no {column} column in the header (found: {}); expected columns named DISPLACEMENT [mm] and FORCE [kN]",
                fields.iter().map(|f| f.trim()).collect::<Vec<_>>().join(", ")
            )
        })
    };
    let (displacement_column, displacement_scale) = find("DISPLACEMENT", &[("mm", 1.0)])?;
    let (force_column, force_scale) = find("FORCE", &[("kN", 1.0), ("N", 1e-3)])?;
    let needed = displacement_column.max(force_column) + 1;

    let mut points = Vec::new();
    for (line_number, line) in lines {
        let fields: Vec<&str> = line.split(',').collect();
        if fields.len() < needed {
            return Err(format!(
                "{name}:{line_number}: expected at least {needed} comma-separated fields (DISPLACEMENT in field {}, FORCE in field {}), found {}",
                displacement_column + 1,
                force_column + 1,
                fields.len()
            ));
        }
        let number = |column: usize, label: &str| -> std::result::Result<f64, String> {
            let text = fields[column].trim().trim_matches('"').trim();
            match text.parse::<f64>() {
                Ok(value) if value.is_finite() => Ok(value),
                _ => Err(format!(
                    "{name}:{line_number}: expected a finite number for {label}, found {text:?}"
                )),
            }
        };
        points.push(TestPoint {
            displacement_mm: number(displacement_column, "DISPLACEMENT")? * displacement_scale,
            force_kn: number(force_column, "FORCE")? * force_scale,
        });
    }
    Ok(points)
}

/// Engineering and true values of one point.
#[derive(Clone, Copy, Debug)]
struct Derived {
    strain: f64,
    stress_mpa: f64,
}

impl Derived {
    fn true_strain(&self) -> f64 {
        self.strain.ln_1p()
    }

    fn true_stress_mpa(&self) -> f64 {
        self.stress_mpa * (1.0 + self.strain)
    }

    fn plastic_strain(&self, youngs_modulus_mpa: f64) -> f64 {
        self.true_strain() - self.true_stress_mpa() / youngs_modulus_mpa
    }
}

/// Least-squares slope (with intercept) of `y` on `x`.
fn slope(points: &[(f64, f64)]) -> Option<f64> {
    let n = points.len() as f64;
    let mean_x = points.iter().map(|p| p.0).sum::<f64>() / n;
    let mean_y = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = points.iter().map(|p| (p.0 - mean_x).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mean_x) * (p.1 - mean_y)).sum();
    let slope = sxy / sxx;
    (sxx > 0.0 && slope.is_finite()).then_some(slope)
}

/// Fits of true stress on true strain to the last 2..=6 points of
/// `true_curve` (which ends at the UTS), and the bounds of m.
pub fn post_uts_slope_bounds(
    true_curve: &[(f64, f64)],
) -> std::result::Result<PostUtsSlope, String> {
    let fits: Vec<SlopeFit> = (2..=SLOPE_FIT_MAX_POINTS.min(true_curve.len()))
        .filter_map(|points| {
            slope(&true_curve[true_curve.len() - points..])
                .map(|slope_mpa| SlopeFit { points, slope_mpa })
        })
        .collect();
    let max_slope_mpa = fits
        .iter()
        .map(|f| f.slope_mpa)
        .fold(f64::NEG_INFINITY, f64::max);
    if fits.is_empty() {
        return Err("no straight line can be fitted to the points before the UTS (fewer than 2 distinct strains)".into());
    }
    Ok(PostUtsSlope {
        upper_bound_mpa: ((max_slope_mpa / SLOPE_BOUND_STEP_MPA).ceil() * SLOPE_BOUND_STEP_MPA)
            .max(0.0),
        fits,
        max_slope_mpa,
        lower_bound_mpa: 0.0,
    })
}

/// Through-origin fit over the loaded points before `end` whose stress is
/// at most `limit`; falls back to the first 2 loaded points.
fn elastic_fit(curve: &[Derived], end: usize, limit: f64) -> Option<(f64, Vec<usize>, bool)> {
    let loaded: Vec<usize> = (0..end).filter(|&i| curve[i].strain > 0.0).collect();
    let mut used: Vec<usize> = loaded
        .iter()
        .copied()
        .take_while(|&i| curve[i].stress_mpa <= limit)
        .collect();
    let fallback = used.len() < 2;
    if fallback {
        used = loaded.into_iter().take(2).collect();
    }
    if used.is_empty() {
        return None;
    }
    let sxy: f64 = used
        .iter()
        .map(|&i| curve[i].strain * curve[i].stress_mpa)
        .sum();
    let sxx: f64 = used.iter().map(|&i| curve[i].strain.powi(2)).sum();
    let modulus = sxy / sxx;
    (modulus.is_finite() && modulus > 0.0).then_some((modulus, used, fallback))
}

/// Rp0.2 for `modulus_mpa`: the first crossing of the offset line up to
/// point `uts`, as `(point before it, fraction of the way to the next)`.
fn offset_yield(curve: &[Derived], modulus_mpa: f64, uts: usize) -> Option<(usize, f64)> {
    let gap = |d: &Derived| d.stress_mpa - modulus_mpa * (d.strain - YIELD_OFFSET_STRAIN);
    (1..=uts).find_map(|i| {
        let (before, after) = (gap(&curve[i - 1]), gap(&curve[i]));
        (before >= 0.0 && after < 0.0).then(|| (i - 1, before / (before - after)))
    })
}

/// Computes every property of a test curve, in stages: the input's
/// checks, the engineering curve, the UTS, E with Rp0.2, the flow curve,
/// and the bounds of the post-UTS slope. Each stage adds its notes in turn.
pub fn tensile_properties(
    points: &[TestPoint],
    geometry: SpecimenGeometry,
) -> std::result::Result<TensileProperties, String> {
    let area = checked_area_mm2(points, geometry)?;
    let mut notes = Vec::new();
    let first = points[0];
    if first.displacement_mm != 0.0 || first.force_kn != 0.0 {
        notes.push(format!(
            "the curve starts at ({} mm, {} kN), not at the origin; E is fitted through the origin and assumes a zeroed curve",
            first.displacement_mm, first.force_kn
        ));
    }
    let curve: Vec<Derived> = points
        .iter()
        .map(|p| Derived {
            strain: p.displacement_mm / geometry.strain_length_mm,
            stress_mpa: 1000.0 * p.force_kn / area,
        })
        .collect();
    let uts_point = uts_point(points, &curve)?;
    let at_uts = curve[uts_point];
    let (modulus, elastic_fit, (after_point, fraction)) =
        elastic_fit_and_yield(&curve, uts_point, &mut notes)?;
    let yield_point = yield_point(points, &curve, after_point, fraction);
    let flow_curve = flow_curve(&curve, modulus, after_point, uts_point, &mut notes);
    let post_uts_slope = post_uts_slope(&curve, uts_point, &flow_curve, &mut notes)?;
    Ok(TensileProperties {
        diameter_mm: geometry.diameter_mm,
        strain_length_mm: geometry.strain_length_mm,
        area_mm2: area,
        test_points: points.len(),
        youngs_modulus_mpa: modulus,
        elastic_fit,
        yield_point,
        uts: Uts {
            point: uts_point,
            force_kn: points[uts_point].force_kn,
            displacement_mm: points[uts_point].displacement_mm,
            engineering_stress_mpa: at_uts.stress_mpa,
            engineering_strain: at_uts.strain,
            true_stress_mpa: at_uts.true_stress_mpa(),
            true_strain: at_uts.true_strain(),
        },
        flow_curve,
        post_uts_slope,
        notes,
    })
}

/// The specimen's cross-section, mm^2, once the geometry and the curve
/// are fit to read: positive sizes, three points or more, a displacement
/// that runs forward.
fn checked_area_mm2(
    points: &[TestPoint],
    geometry: SpecimenGeometry,
) -> std::result::Result<f64, String> {
    let area = geometry.area_mm2();
    let positive = |value: f64| value.is_finite() && value > 0.0;
    if !positive(geometry.diameter_mm) || !positive(geometry.strain_length_mm) || !positive(area) {
        return Err(format!(
            "the diameter ({} mm) and strain length ({} mm) must be positive",
            geometry.diameter_mm, geometry.strain_length_mm
        ));
    }
    if points.len() < 3 {
        return Err(format!(
            "the curve has {} points; at least 3 are needed",
            points.len()
        ));
    }
    // A curve whose displacement does not run forward has no elastic line
    // to offset: say what is wrong with the displacement itself.
    let (low, high) = points
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| {
            (l.min(p.displacement_mm), h.max(p.displacement_mm))
        });
    let (start, end) = (
        points[0].displacement_mm,
        points[points.len() - 1].displacement_mm,
    );
    if low == high {
        return Err(format!(
            "the displacement never changes (it is {low} mm at all {} points): is DISPLACEMENT the extensometer's column?",
            points.len()
        ));
    }
    if end < start {
        return Err(format!(
            "the displacement runs backwards, from {start} mm to {end} mm: a pull lengthens the specimen (check the extensometer's sign, or the order of the rows)"
        ));
    }
    Ok(area)
}

/// The UTS: the first maximum of the force.
fn uts_point(points: &[TestPoint], curve: &[Derived]) -> std::result::Result<usize, String> {
    let uts_point = points.iter().enumerate().fold(0, |best, (i, p)| {
        if p.force_kn > points[best].force_kn {
            i
        } else {
            best
        }
    });
    if uts_point == 0 || points[uts_point].force_kn <= 0.0 {
        return Err("the force never rises above its first value; is this a tensile test?".into());
    }
    let at_uts = curve[uts_point];
    if at_uts.strain <= -1.0 {
        return Err("the strain at the maximum force is -100 % or less".into());
    }

    Ok(uts_point)
}

/// E and Rp0.2, iterated until the elastic points settle: the modulus,
/// its fit, and the offset line's crossing (point before it, fraction).
fn elastic_fit_and_yield(
    curve: &[Derived],
    uts_point: usize,
    notes: &mut Vec<String>,
) -> std::result::Result<(f64, ElasticFit, (usize, f64)), String> {
    let at_uts = curve[uts_point];
    let uts_limit = ELASTIC_LIMIT_UTS_FRACTION * at_uts.stress_mpa;
    let mut limit = uts_limit;
    let mut previous: Option<Vec<usize>> = None;
    let mut rounds = 0;
    let (modulus, used, fallback, (after_point, fraction)) = loop {
        rounds += 1;
        let (modulus, used, fallback) = elastic_fit(curve, uts_point, limit)
            .ok_or("no loaded point with positive strain before the maximum force: cannot fit E")?;
        let crossing = offset_yield(curve, modulus, uts_point).ok_or_else(|| {
            format!(
                "the curve never falls 0.2 % below the elastic line (E = {modulus:.0} MPa) before the maximum force: no offset yield"
            )
        })?;
        let (i, t) = crossing;
        let yield_stress =
            curve[i].stress_mpa + t * (curve[i + 1].stress_mpa - curve[i].stress_mpa);
        let settled = previous.as_ref() == Some(&used);
        if settled || rounds == MAX_ELASTIC_ROUNDS {
            if !settled {
                notes.push(format!(
                    "the elastic fit did not settle in {MAX_ELASTIC_ROUNDS} rounds; the last one is used"
                ));
            }
            break (modulus, used, fallback, crossing);
        }
        previous = Some(used);
        limit = uts_limit.min(ELASTIC_LIMIT_YIELD_FRACTION * yield_stress);
    };
    if fallback {
        notes.push(format!(
            "fewer than 2 loaded points below {limit:.1} MPa: E is fitted to the first {} loaded points",
            used.len()
        ));
    }
    let residuals: f64 = used
        .iter()
        .map(|&i| (curve[i].stress_mpa - modulus * curve[i].strain).powi(2))
        .sum();
    let elastic_fit = ElasticFit {
        method: "least squares through the origin, engineering stress on engineering strain, loaded points up to min(60 % UTS, 80 % Rp0.2)".into(),
        first_point: used[0],
        last_point: used[used.len() - 1],
        points_used: used.len(),
        stress_limit_mpa: limit,
        max_stress_used_mpa: used
            .iter()
            .map(|&i| curve[i].stress_mpa)
            .fold(f64::NEG_INFINITY, f64::max),
        rms_residual_mpa: (residuals / used.len() as f64).sqrt(),
    };
    if used.len() < 4 {
        notes.push(format!(
            "E rests on {} point(s) only; the modulus is uncertain",
            used.len()
        ));
    }

    Ok((modulus, elastic_fit, (after_point, fraction)))
}

/// Rp0.2 read linearly between the measured points around the crossing.
fn yield_point(
    points: &[TestPoint],
    curve: &[Derived],
    after_point: usize,
    fraction: f64,
) -> YieldPoint {
    let lerp = |a: f64, b: f64| a + fraction * (b - a);
    let (before, after) = (curve[after_point], curve[after_point + 1]);
    let yield_derived = Derived {
        strain: lerp(before.strain, after.strain),
        stress_mpa: lerp(before.stress_mpa, after.stress_mpa),
    };
    YieldPoint {
        method: "0.2 % offset (Rp0.2), read linearly between measured points".into(),
        stress_mpa: yield_derived.stress_mpa,
        strain: yield_derived.strain,
        displacement_mm: lerp(
            points[after_point].displacement_mm,
            points[after_point + 1].displacement_mm,
        ),
        force_kn: lerp(
            points[after_point].force_kn,
            points[after_point + 1].force_kn,
        ),
        true_stress_mpa: yield_derived.true_stress_mpa(),
        true_strain: yield_derived.true_strain(),
        after_point,
    }
}

/// The flow curve from the onset of plasticity (the last zero crossing of
/// the plastic strain before Rp0.2) to the UTS, unshifted; a noisy one
/// pooled so it rises and averaged over plastic-strain bins.
fn flow_curve(
    curve: &[Derived],
    modulus: f64,
    after_point: usize,
    uts_point: usize,
    notes: &mut Vec<String>,
) -> FlowCurve {
    let onset_point = (0..=after_point)
        .rev()
        .find(|&i| curve[i].plastic_strain(modulus) <= 0.0)
        .unwrap_or(0);
    let (below, above) = (curve[onset_point], curve[onset_point + 1]);
    let (plastic_below, plastic_above) = (
        below.plastic_strain(modulus).min(0.0),
        above.plastic_strain(modulus),
    );
    let onset_fraction = if plastic_above > plastic_below {
        -plastic_below / (plastic_above - plastic_below)
    } else {
        0.0
    };
    let onset = Derived {
        strain: below.strain + onset_fraction * (above.strain - below.strain),
        stress_mpa: below.stress_mpa + onset_fraction * (above.stress_mpa - below.stress_mpa),
    };
    let mut flow = vec![FlowPoint {
        plastic_strain: 0.0,
        true_stress_mpa: onset.true_stress_mpa(),
    }];
    let mut dropped_non_increasing = 0;
    for point in &curve[onset_point + 1..=uts_point] {
        let plastic_strain = point.plastic_strain(modulus);
        if plastic_strain <= flow[flow.len() - 1].plastic_strain {
            dropped_non_increasing += 1;
        } else {
            flow.push(FlowPoint {
                plastic_strain,
                true_stress_mpa: point.true_stress_mpa(),
            });
        }
    }
    if dropped_non_increasing > 0 {
        notes.push(format!(
            "flow curve: dropped {dropped_non_increasing} point(s) whose plastic strain does not increase"
        ));
    }
    let measured_rows = flow.len();
    let mut flow = pool_to_increasing_stress(flow);
    let pooled_for_increasing_stress = measured_rows - flow.len();
    if pooled_for_increasing_stress > 0 {
        // A noisy curve: also average it over plastic-strain bins, so the
        // hardening slope between rows is not the noise over a sample step.
        flow = average_over_bins(&flow, NOISY_FLOW_BIN);
        notes.push(format!(
            "flow curve: the true stress fell between some of the {measured_rows} measured rows (noise); \
             pooled so it rises, then averaged over plastic-strain bins of {NOISY_FLOW_BIN}: {} rows \
             (a falling or jagged table gives the FE model softening and kinks it cannot converge through)",
            flow.len()
        ));
    }

    FlowCurve {
        points: flow,
        onset_after_point: onset_point,
        onset_strain: onset.strain,
        dropped_non_increasing,
        pooled_for_increasing_stress,
    }
}

/// The bounds of the post-UTS slope m, fitted on the true curve up to the
/// UTS, or on a noisy curve's averaged flow table.
fn post_uts_slope(
    curve: &[Derived],
    uts_point: usize,
    flow_curve: &FlowCurve,
    notes: &mut Vec<String>,
) -> std::result::Result<PostUtsSlope, String> {
    let (flow, pooled_for_increasing_stress) =
        (&flow_curve.points, flow_curve.pooled_for_increasing_stress);
    let true_curve: Vec<(f64, f64)> = curve[..=uts_point]
        .iter()
        .map(|d| (d.true_strain(), d.true_stress_mpa()))
        .collect();
    // A noisy curve's last few points give a slope of its noise: fit its
    // averaged table instead (plastic strain for true strain: past yield
    // they differ by the elastic strain, whose slope is 1/E of the stress's).
    let slope_points: Vec<(f64, f64)> = if pooled_for_increasing_stress > 0 {
        flow.iter()
            .map(|p| (p.plastic_strain, p.true_stress_mpa))
            .collect()
    } else {
        true_curve
    };
    let post_uts_slope = post_uts_slope_bounds(&slope_points)?;
    if post_uts_slope.fits.len() < SLOPE_FIT_MAX_POINTS - 1 {
        notes.push(format!(
            "only {} point(s) up to the UTS: {} slope fit(s) instead of {}",
            uts_point + 1,
            post_uts_slope.fits.len(),
            SLOPE_FIT_MAX_POINTS - 1
        ));
    }
    if post_uts_slope.max_slope_mpa <= 0.0 {
        notes
            .push("the true stress does not rise before the UTS: the upper bound of m is 0".into());
    }

    Ok(post_uts_slope)
}

/// Plastic-strain bin of a noisy flow curve's table (0.2 %: about 50 rows
/// up to a UTS at 10 % strain; a clean curve's table is kept row by row).
pub const NOISY_FLOW_BIN: f64 = 0.002;

/// Rows averaged over bins `[k bin, (k+1) bin)` of plastic strain; the
/// first row (plastic strain 0) stays. Averages of a rising table rise.
pub fn average_over_bins(flow: &[FlowPoint], bin: f64) -> Vec<FlowPoint> {
    let Some((&onset, rest)) = flow.split_first() else {
        return flow.to_vec();
    };
    let mut averaged = vec![onset];
    let mut current: Option<(i64, f64, f64, f64)> = None;
    let close = |block: (i64, f64, f64, f64), out: &mut Vec<FlowPoint>| {
        out.push(FlowPoint {
            plastic_strain: block.1 / block.3,
            true_stress_mpa: block.2 / block.3,
        });
    };
    for point in rest {
        let key = (point.plastic_strain / bin).floor() as i64;
        match &mut current {
            Some(block) if block.0 == key => {
                block.1 += point.plastic_strain;
                block.2 += point.true_stress_mpa;
                block.3 += 1.0;
            }
            _ => {
                if let Some(block) = current.take() {
                    close(block, &mut averaged);
                }
                current = Some((key, point.plastic_strain, point.true_stress_mpa, 1.0));
            }
        }
    }
    if let Some(block) = current {
        close(block, &mut averaged);
    }
    averaged
}

/// The least-squares non-decreasing fit of the stress (pool adjacent
/// violators), each pooled block then one row at its mean plastic strain
/// and mean stress, so the stress rises strictly from row to row.
///
/// Before the UTS the true stress of a real material rises; where a
/// measured curve falls locally that is noise, and a table with falling
/// stretches would give the FE model material softening (it then fails to
/// converge). On a curve whose stress already rises this is the identity.
/// The first row (the onset of plasticity, plastic strain 0) stays; a
/// block that does not rise above it is dropped.
pub fn pool_to_increasing_stress(flow: Vec<FlowPoint>) -> Vec<FlowPoint> {
    let Some((&onset, rest)) = flow.split_first() else {
        return flow;
    };
    // (sum of plastic strain, sum of stress, count) per block.
    let mut blocks: Vec<(f64, f64, f64)> = Vec::with_capacity(rest.len());
    for point in rest {
        blocks.push((point.plastic_strain, point.true_stress_mpa, 1.0));
        while let [.., previous, last] = blocks[..] {
            if last.1 / last.2 > previous.1 / previous.2 {
                break;
            }
            blocks.pop();
            let merged = blocks.last_mut().expect("two blocks were there");
            merged.0 += last.0;
            merged.1 += last.1;
            merged.2 += last.2;
        }
    }
    // A first block at or below the onset stress cannot rise above it:
    // the onset row already says that level.
    let mut pooled = vec![onset];
    for (strain_sum, stress_sum, count) in blocks {
        let stress = stress_sum / count;
        if stress > pooled[pooled.len() - 1].true_stress_mpa {
            pooled.push(FlowPoint {
                plastic_strain: strain_sum / count,
                true_stress_mpa: stress,
            });
        }
    }
    pooled
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bins_average_rows_and_keep_the_onset() {
        let row = |plastic_strain: f64, true_stress_mpa: f64| FlowPoint {
            plastic_strain,
            true_stress_mpa,
        };
        let flow = vec![
            row(0.0, 400.0),
            row(0.0005, 410.0),
            row(0.0015, 420.0),
            row(0.0025, 440.0),
            row(0.0041, 450.0),
        ];
        let averaged = average_over_bins(&flow, 0.002);
        assert_eq!(averaged.len(), 4);
        assert_eq!(averaged[0], row(0.0, 400.0));
        assert!((averaged[1].plastic_strain - 0.001).abs() < 1e-15);
        assert!((averaged[1].true_stress_mpa - 415.0).abs() < 1e-12);
        assert_eq!(averaged[2], row(0.0025, 440.0));
        assert_eq!(averaged[3], row(0.0041, 450.0));
    }

    #[test]
    fn pooling_keeps_a_rising_curve_and_averages_a_falling_stretch() {
        let row = |plastic_strain: f64, true_stress_mpa: f64| FlowPoint {
            plastic_strain,
            true_stress_mpa,
        };
        let rising = vec![row(0.0, 400.0), row(0.01, 450.0), row(0.02, 480.0)];
        assert_eq!(pool_to_increasing_stress(rising.clone()), rising);
        // 500, 490 fall: pooled to one row at their means (0.025, 495).
        let noisy = vec![
            row(0.0, 400.0),
            row(0.01, 450.0),
            row(0.02, 500.0),
            row(0.03, 490.0),
            row(0.04, 520.0),
        ];
        let pooled = pool_to_increasing_stress(noisy);
        assert_eq!(
            pooled,
            vec![
                row(0.0, 400.0),
                row(0.01, 450.0),
                row(0.025, 495.0),
                row(0.04, 520.0)
            ]
        );
        // A violation that reaches back two blocks: 500, 460, 430 after 450
        // pool into one block of mean 460 > 450; then 440 < 460 joins it
        // (mean 457.5) and the whole block stays above 450.
        let deep = vec![
            row(0.0, 400.0),
            row(0.01, 450.0),
            row(0.02, 500.0),
            row(0.03, 460.0),
            row(0.04, 430.0),
            row(0.05, 440.0),
        ];
        let pooled = pool_to_increasing_stress(deep);
        assert_eq!(pooled.len(), 3);
        assert!((pooled[2].true_stress_mpa - 457.5).abs() < 1e-12);
        assert!((pooled[2].plastic_strain - 0.035).abs() < 1e-12);
        // Rows below the onset stress are dropped, never put before it.
        let dip = vec![row(0.0, 400.0), row(0.01, 390.0), row(0.02, 420.0)];
        assert_eq!(
            pool_to_increasing_stress(dip),
            vec![row(0.0, 400.0), row(0.02, 420.0)]
        );
    }

    #[test]
    fn slope_bounds_match_a_hand_computation() {
        // Last points (true strain, true stress): slopes by hand
        // 2 points: (650 - 640) / (0.10 - 0.09) = 1000
        // 3 points: x = 0.08, 0.09, 0.10; y = 625, 640, 650:
        //   mean x 0.09, mean y 638.33; sxy = (-0.01)(-13.33) + 0 + (0.01)(11.67) = 0.25,
        //   sxx = 0.0002 -> 1250
        // 4 points adds (0.07, 615): x mean 0.085, y mean 632.5,
        //   sxy = (-0.015)(-17.5) + (-0.005)(-7.5) + (0.005)(7.5) + (0.015)(17.5) = 0.6,
        //   sxx = 0.0005 -> 1200
        let curve = [(0.07, 615.0), (0.08, 625.0), (0.09, 640.0), (0.10, 650.0)];
        let bounds = post_uts_slope_bounds(&curve).unwrap();
        let slopes: Vec<f64> = bounds.fits.iter().map(|f| f.slope_mpa).collect();
        assert_eq!(
            bounds.fits.iter().map(|f| f.points).collect::<Vec<_>>(),
            [2, 3, 4]
        );
        for (got, expected) in slopes.iter().zip([1000.0, 1250.0, 1200.0]) {
            assert!((got - expected).abs() < 1e-9, "{slopes:?}");
        }
        assert_eq!(bounds.max_slope_mpa, slopes[1]);
        assert_eq!(bounds.upper_bound_mpa, 1250.0);
        assert_eq!(bounds.lower_bound_mpa, 0.0);

        // 799 rounds up to 800, 800.01 to 850, a falling curve to 0.
        let bound = |slope: f64| {
            post_uts_slope_bounds(&[(0.0, 100.0), (1.0, 100.0 + slope)])
                .unwrap()
                .upper_bound_mpa
        };
        assert_eq!(bound(799.0), 800.0);
        assert_eq!(bound(800.0), 800.0);
        assert_eq!(bound(800.01), 850.0);
        assert_eq!(bound(-20.0), 0.0);
        assert!(post_uts_slope_bounds(&[(0.1, 1.0), (0.1, 2.0)]).is_err());
    }

    /// A bilinear material: E = 200 GPa up to 400 MPa, then 2 GPa
    /// hardening, sampled every 0.0002 strain up to 0.03; displacement over
    /// 12.5 mm.
    fn bilinear() -> Vec<TestPoint> {
        let geometry = SpecimenGeometry::default();
        let mut points: Vec<TestPoint> = (0..=150)
            .map(|i| {
                let strain = 0.0002 * i as f64;
                let stress = if strain <= 0.002 {
                    200_000.0 * strain
                } else {
                    400.0 + 2000.0 * (strain - 0.002)
                };
                TestPoint {
                    displacement_mm: strain * geometry.strain_length_mm,
                    force_kn: stress * geometry.area_mm2() / 1000.0,
                }
            })
            .collect();
        // Necking: the force falls after the maximum.
        let last = points[points.len() - 1];
        points.push(TestPoint {
            displacement_mm: last.displacement_mm + 0.01,
            force_kn: 0.9 * last.force_kn,
        });
        points
    }

    #[test]
    fn a_bilinear_curve_gives_its_modulus_yield_and_flow_curve() {
        let properties = tensile_properties(&bilinear(), SpecimenGeometry::default()).unwrap();
        assert!((properties.youngs_modulus_mpa - 200_000.0).abs() < 1e-6);
        // Offset line s = E (e - 0.002) meets 400 + 2000 (e - 0.002) at
        // e - 0.002 = 400 / 198000.
        let expected_yield = 400.0 + 2000.0 * 400.0 / 198_000.0;
        assert!((properties.yield_point.stress_mpa - expected_yield).abs() < 1e-6);
        assert_eq!(properties.uts.point, 150);
        // 6 points up to 60 % of the UTS stress (456 MPa).
        assert_eq!(properties.elastic_fit.points_used, 6);
        // The crossing at strain 0.00402 lies between points 20 and 21.
        assert_eq!(properties.yield_point.after_point, 20);
        let flow = &properties.flow_curve.points;
        assert_eq!(flow[0].plastic_strain, 0.0);
        assert!(flow
            .windows(2)
            .all(|w| w[1].plastic_strain > w[0].plastic_strain));
        // Plasticity starts at the kink (strain 0.002, point 10): the first
        // row is there, at the true stress 400 (1.002), then points 11..=150.
        assert_eq!(properties.flow_curve.onset_after_point, 10);
        assert!((properties.flow_curve.onset_strain - 0.002).abs() < 1e-4);
        assert!((flow[0].true_stress_mpa - 400.0 * 1.002).abs() < 0.1);
        assert_eq!(flow.len(), 1 + 150 - 10);
        // Unshifted: plastic + elastic true strain is the measured true
        // strain, so a uniform model retraces the test.
        let last = flow[flow.len() - 1];
        let uts_true_strain = properties.uts.true_strain;
        assert!(
            (last.plastic_strain + last.true_stress_mpa / 200_000.0 - uts_true_strain).abs()
                < 1e-12
        );
        let hardening: Vec<f64> = properties
            .post_uts_slope
            .fits
            .iter()
            .map(|f| f.slope_mpa)
            .collect();
        assert_eq!(hardening.len(), 5);
        assert!(properties.notes.is_empty(), "{:?}", properties.notes);
    }

    #[test]
    fn parses_columns_by_name_with_units_and_reports_bad_rows() {
        let text = "# comment\nTIME,force [N],Displacement (mm)\n0,0,0\n1,1000,0.5\n\n2,2000,1.0\n";
        let points = parse_test_csv(text, "t.csv").unwrap();
        assert_eq!(points.len(), 3);
        assert_eq!(
            points[2],
            TestPoint {
                displacement_mm: 1.0,
                force_kn: 2.0
            }
        );
        let error = parse_test_csv("DISPLACEMENT,FORCE\n0,0\n0.1,x\n", "t.csv").unwrap_err();
        assert!(
            error.starts_with("t.csv:3: expected a finite number for FORCE"),
            "{error}"
        );
        let error = parse_test_csv("DISPLACEMENT,FORCE\n0,0\n0.1\n", "t.csv").unwrap_err();
        assert!(error.starts_with("t.csv:3: expected at least 2"), "{error}");
        let error = parse_test_csv("DISPLACEMENT,LOAD\n0,0\n", "t.csv").unwrap_err();
        assert!(error.contains("no FORCE column"), "{error}");
        let error = parse_test_csv("DISPLACEMENT [in],FORCE\n0,0\n", "t.csv").unwrap_err();
        assert!(
            error.contains("DISPLACEMENT is in [in]; expected [mm]"),
            "{error}"
        );
        let error = parse_test_csv("DISPLACEMENT,FORCE,force\n", "t.csv").unwrap_err();
        assert!(error.contains("two FORCE columns"), "{error}");
        assert!(parse_test_csv("DISPLACEMENT,FORCE\n0,NaN\n", "t.csv").is_err());
    }

    #[test]
    fn degenerate_curves_are_errors() {
        let geometry = SpecimenGeometry::default();
        let flat: Vec<TestPoint> = (0..5)
            .map(|i| TestPoint {
                displacement_mm: i as f64,
                force_kn: 0.0,
            })
            .collect();
        assert!(tensile_properties(&flat, geometry).is_err());
        assert!(tensile_properties(&flat[..2], geometry).is_err());
        let bad_geometry = SpecimenGeometry {
            diameter_mm: 0.0,
            strain_length_mm: 12.5,
        };
        assert!(tensile_properties(&bilinear(), bad_geometry).is_err());
        // Elastic all the way to the maximum: no offset yield.
        let elastic: Vec<TestPoint> = (0..6)
            .map(|i| TestPoint {
                displacement_mm: 0.001 * i as f64,
                force_kn: i as f64,
            })
            .collect();
        let error = tensile_properties(&elastic, geometry).unwrap_err();
        assert!(error.contains("no offset yield"), "{error}");
    }
}
