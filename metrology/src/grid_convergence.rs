//! The discretisation error of a solver's output, from the same run at
//! several element sizes: the numerical uncertainty `u_num` of ASME V&V 20.
//!
//! - Three sizes: the procedure of Celik et al. 2008 (ASME J. Fluids Eng.
//!   130, 078001; cited by `measurement-chain.md`): the apparent order `p`
//!   from the two differences (fixed-point iteration when the refinement
//!   ratios differ), Richardson extrapolation, the approximate and
//!   extrapolated relative errors, and the fine grid's convergence index
//!   `GCI_fine = 1.25 e_a / (r21^p - 1)`.
//! - More sizes: the least-squares form of Eça and Hoekstra 2014: `phi0`,
//!   `alpha` and `p` fitted to `phi_i = phi0 + alpha h_i^p` over every
//!   size, and `GCI_fine = (1.25 |phi0 - phi_1| + U_s) / |phi_1|`, `U_s`
//!   the fit's standard deviation.
//!
//! The convergence is named from the differences between neighbouring
//! sizes (fine to coarse), `e21 = phi_2 - phi_1` and `e32 = phi_3 -
//! phi_2`: of one sign, monotonic where a positive order fits them, which
//! is `e32 / e21 > ln r32 / ln r21` (with equal ratios the usual `0 < R <
//! 1`, `R = e21 / e32`; with unequal ones the finer step may well change
//! the value more); of opposite signs, oscillatory while `|R| < 1`;
//! anything else divergent; values that agree within round-off
//! ([`ROUND_OFF_RELATIVE`]) are mesh-independent, with no order. Where the
//! procedure does not apply (divergence, a zero
//! value, a fit that does not converge) its numbers are `None` and the
//! note says why: never a silent number.

/// How the values approach the fine grid's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Convergence {
    Monotonic,
    Oscillatory,
    Divergent,
    /// The values agree within round-off ([`ROUND_OFF_RELATIVE`]): the
    /// output does not depend on the mesh, and no order can be observed.
    MeshIndependent,
}

impl Convergence {
    pub fn name(self) -> &'static str {
        match self {
            Convergence::Monotonic => "monotonic",
            Convergence::Oscillatory => "oscillatory",
            Convergence::Divergent => "divergent",
            Convergence::MeshIndependent => "mesh-independent",
        }
    }
}

/// Values whose spread is at most this fraction of their magnitude agree
/// within round-off: a solver's output printed to seven significant digits
/// (CalculiX's `.dat` tables; a single-precision float holds about 7.2)
/// moves in its seventh digit for reasons that are not the mesh. Celik's
/// procedure then has no difference to take an order from.
pub const ROUND_OFF_RELATIVE: f64 = 1e-6;

/// The safety factor of a three-grid study with a computed order (Roache;
/// Celik et al. 2008).
pub const SAFETY_FACTOR: f64 = 1.25;

/// One output's grid convergence.
#[derive(Clone, Debug, PartialEq)]
pub struct GridConvergence {
    /// Representative element sizes, finest first, and the values there.
    pub sizes: Vec<f64>,
    pub values: Vec<f64>,
    pub convergence: Convergence,
    /// The apparent (observed) order `p`.
    pub order: Option<f64>,
    /// The value at zero element size (Richardson extrapolation, or the
    /// fit's `phi0`).
    pub extrapolated: Option<f64>,
    /// `|phi_1 - phi_2| / |phi_1|` of the two finest sizes, %.
    pub e_a_pct: Option<f64>,
    /// `|phi_ext - phi_1| / |phi_ext|`, %.
    pub e_ext_pct: Option<f64>,
    /// The fine grid's convergence index, % of `|phi_1|`: the discretisation
    /// error's bound with about 95 % confidence.
    pub gci_fine_pct: Option<f64>,
    /// The factor of safety in the GCI: 1.25 where an order was observed,
    /// 3 for the least-squares form's oscillatory bound.
    pub safety_factor: f64,
    /// Which procedure gave the numbers, and why any is missing.
    pub note: String,
}

impl GridConvergence {
    /// `u_num` of V&V 20 in the output's unit: the GCI without its factor
    /// of safety, which plays the part of a coverage factor (for a
    /// three-grid study, `|phi_ext - phi_1|`, the error Richardson
    /// extrapolation estimates).
    pub fn standard_uncertainty(&self) -> Option<f64> {
        Some(self.gci_fine_pct? / 100.0 * self.values[0].abs() / self.safety_factor)
    }

    /// `u_num` of a run at `size`, one of the study's: its distance from
    /// the extrapolated value, which at the finest size is
    /// [`GridConvergence::standard_uncertainty`]; a coarser size has a
    /// larger one. `None` without an extrapolated value (and for a size
    /// the study does not have).
    pub fn standard_uncertainty_at(&self, size: f64) -> Option<f64> {
        let at = self.sizes.iter().position(|&h| h == size)?;
        if at == 0 {
            return self.standard_uncertainty();
        }
        Some((self.values[at] - self.extrapolated?).abs())
    }
}

/// One line: `monotonic; order 1.530, extrapolated 6.1685, GCI_fine 2.200 %`
/// (`-` for a number the procedure does not give).
impl std::fmt::Display for GridConvergence {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let text = |v: Option<f64>, decimals: usize| {
            v.map_or_else(|| "-".to_string(), |v| format!("{v:.decimals$}"))
        };
        write!(
            f,
            "{}; order {}, extrapolated {}, GCI_fine {} %",
            self.convergence.name(),
            text(self.order, 3),
            text(self.extrapolated, 6),
            text(self.gci_fine_pct, 3)
        )
    }
}

/// The grid convergence of `values` at `sizes` (any order; at least three
/// distinct positive sizes).
///
/// # Errors
/// Fewer than three sizes, sizes not distinct and positive, a value not
/// finite, or lengths that differ.
pub fn grid_convergence(sizes: &[f64], values: &[f64]) -> Result<GridConvergence, String> {
    if sizes.len() != values.len() {
        return Err(format!(
            "{} sizes and {} values: give one value per size",
            sizes.len(),
            values.len()
        ));
    }
    if sizes.len() < 3 {
        return Err(format!(
            "{} sizes: a grid convergence study needs at least three",
            sizes.len()
        ));
    }
    if let Some(bad) = sizes.iter().find(|h| !(h.is_finite() && **h > 0.0)) {
        return Err(format!(
            "element size {bad}: sizes must be positive numbers"
        ));
    }
    if let Some(bad) = values.iter().find(|v| !v.is_finite()) {
        return Err(format!("value {bad}: every value must be a finite number"));
    }
    let mut pairs: Vec<(f64, f64)> = sizes.iter().copied().zip(values.iter().copied()).collect();
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    if pairs.windows(2).any(|w| w[0].0 == w[1].0) {
        return Err("two sizes are equal: give each element size once".into());
    }
    let (sizes, values): (Vec<f64>, Vec<f64>) = pairs.into_iter().unzip();
    if let Some(study) = mesh_independent(&sizes, &values) {
        return Ok(study);
    }
    let convergence = convergence_of(&sizes, &values);
    let e_a_pct = relative_pct(values[0] - values[1], values[0]);
    let base = GridConvergence {
        sizes,
        values,
        convergence,
        order: None,
        extrapolated: None,
        e_a_pct,
        e_ext_pct: None,
        gci_fine_pct: None,
        safety_factor: SAFETY_FACTOR,
        note: String::new(),
    };
    Ok(if base.sizes.len() == 3 {
        three_grids(base)
    } else {
        least_squares(base)
    })
}

/// Values that agree within round-off: the finest is the value, with the
/// spread as its `u_num` (the GCI of safety factor 1: a bound, not an
/// extrapolation).
fn mesh_independent(sizes: &[f64], values: &[f64]) -> Option<GridConvergence> {
    let (low, high) = values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    let magnitude = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let spread = high - low;
    if spread > ROUND_OFF_RELATIVE * magnitude {
        return None;
    }
    let fine = values[0];
    Some(GridConvergence {
        sizes: sizes.to_vec(),
        values: values.to_vec(),
        convergence: Convergence::MeshIndependent,
        order: None,
        extrapolated: Some(fine),
        e_a_pct: relative_pct(values[0] - values[1], fine),
        e_ext_pct: Some(0.0),
        gci_fine_pct: relative_pct(spread, fine).or(Some(0.0)),
        safety_factor: 1.0,
        note: match spread {
            0.0 => "the values are equal (to round-off): the output does not depend on the mesh, so no order is observed; u_num is 0".into(),
            _ => format!(
                "the values agree within round-off (their spread is {:.1e} of their magnitude, at most {ROUND_OFF_RELATIVE:e}): the output does not depend on the mesh, so no order is observed; u_num is the spread",
                spread / magnitude
            ),
        },
    })
}

/// `100 |difference / reference|`; `None` when the reference is zero.
fn relative_pct(difference: f64, reference: f64) -> Option<f64> {
    (reference != 0.0).then(|| 100.0 * (difference / reference).abs())
}

/// The convergence from the differences of neighbouring values, finest
/// first: the worst triple decides.
fn convergence_of(sizes: &[f64], values: &[f64]) -> Convergence {
    let mut worst = Convergence::Monotonic;
    for (h, w) in sizes.windows(3).zip(values.windows(3)) {
        let (fine, coarse) = (w[1] - w[0], w[2] - w[1]);
        // `phi = phi0 + a h^p` gives `coarse / fine = r21^p (r32^p - 1) /
        // (r21^p - 1)`, which tends to `ln r32 / ln r21` as p -> 0.
        let (r21, r32) = (h[1] / h[0], h[2] / h[1]);
        let order_zero = r32.ln() / r21.ln();
        let kind = if fine == 0.0 && coarse == 0.0 {
            Convergence::Monotonic
        } else if fine == 0.0 {
            // The finest pair agrees while the coarse one differs.
            Convergence::Monotonic
        } else if coarse == 0.0 {
            Convergence::Divergent
        } else {
            let ratio = coarse / fine;
            if ratio > order_zero {
                Convergence::Monotonic
            } else if ratio < -1.0 {
                Convergence::Oscillatory
            } else {
                Convergence::Divergent
            }
        };
        worst = match (worst, kind) {
            (Convergence::Divergent, _) | (_, Convergence::Divergent) => Convergence::Divergent,
            (Convergence::Oscillatory, _) | (_, Convergence::Oscillatory) => {
                Convergence::Oscillatory
            }
            _ => Convergence::Monotonic,
        };
    }
    worst
}

/// Celik et al. 2008, steps 1-5, on three sizes.
fn three_grids(mut study: GridConvergence) -> GridConvergence {
    let [h1, h2, h3] = [study.sizes[0], study.sizes[1], study.sizes[2]];
    let [phi1, phi2, phi3] = [study.values[0], study.values[1], study.values[2]];
    let (r21, r32) = (h2 / h1, h3 / h2);
    let (e21, e32) = (phi2 - phi1, phi3 - phi2);
    const PROCEDURE: &str = "three grids, Celik et al. 2008";
    if study.convergence == Convergence::Divergent {
        study.note = format!("{PROCEDURE}: the values diverge as the elements shrink (R = {}; they span {}); no order, extrapolation or GCI: refine further, or look for an error that grows with refinement (a singularity, an iterative tolerance)", ratio_text(e21, e32), span_text(&study.values));
        return study;
    }
    if e21 == 0.0 {
        study.note = format!("{PROCEDURE}: the two finest values are equal while the coarsest differs; the order cannot be estimated: add a size");
        return study;
    }
    let sign = (e32 / e21).signum();
    let Some(order) = apparent_order(r21, r32, e21, e32, sign) else {
        study.note = format!("{PROCEDURE}: the fixed-point iteration for the apparent order did not converge (R = {}); no order, extrapolation or GCI", ratio_text(e21, e32));
        return study;
    };
    let gain = r21.powf(order);
    let extrapolated = (gain * phi1 - phi2) / (gain - 1.0);
    study.order = Some(order);
    study.extrapolated = Some(extrapolated);
    study.e_ext_pct = relative_pct(extrapolated - phi1, extrapolated);
    study.gci_fine_pct = study.e_a_pct.map(|e_a| SAFETY_FACTOR * e_a / (gain - 1.0));
    study.note = match study.convergence {
        Convergence::Oscillatory => format!("{PROCEDURE}: oscillatory convergence (R = {}); the order uses s = -1 as the procedure does, and its numbers are less certain than a monotonic study's", ratio_text(e21, e32)),
        _ => format!("{PROCEDURE}: monotonic convergence (R = {})", ratio_text(e21, e32)),
    };
    if study.e_a_pct.is_none() {
        study
            .note
            .push_str("; the finest value is 0, so no relative error or GCI");
    }
    study
}

/// The values' range relative to the finest value: a divergence within a
/// solver's tolerance reads very differently from one of 10 %.
fn span_text(values: &[f64]) -> String {
    let (low, high) = values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    match relative_pct(high - low, values[0]) {
        Some(pct) => format!("{pct:.3e} % of the finest value"),
        None => format!("{:.3e}", high - low),
    }
}

fn ratio_text(e21: f64, e32: f64) -> String {
    if e32 == 0.0 {
        "infinite".into()
    } else {
        format!("{:.4}", e21 / e32)
    }
}

/// `p = |ln|e32/e21| + q(p)| / ln r21`, `q(p) = ln((r21^p - s) / (r32^p -
/// s))`, by fixed-point iteration from `q = 0` (exact in one step when the
/// ratios are equal).
fn apparent_order(r21: f64, r32: f64, e21: f64, e32: f64, sign: f64) -> Option<f64> {
    let log_ratio = (e32 / e21).abs().ln();
    let mut order = (log_ratio / r21.ln()).abs();
    for _ in 0..500 {
        let q = ((r21.powf(order) - sign) / (r32.powf(order) - sign)).ln();
        let next = ((log_ratio + q) / r21.ln()).abs();
        if !next.is_finite() {
            return None;
        }
        if (next - order).abs() <= 1e-14 * next.max(1.0) {
            return Some(next);
        }
        order = next;
    }
    None
}

/// The orders the least-squares fit searches: beyond them an order is not
/// a discretisation error's.
const FIT_ORDERS: (f64, f64) = (0.05, 10.0);

/// Eça and Hoekstra 2014 on four or more sizes.
fn least_squares(mut study: GridConvergence) -> GridConvergence {
    const PROCEDURE: &str = "least squares over every size, Eça and Hoekstra 2014";
    let (h, phi) = (&study.sizes, &study.values);
    let range = phi.iter().fold(f64::NEG_INFINITY, |a, &b| a.max(b))
        - phi.iter().fold(f64::INFINITY, |a, &b| a.min(b));
    match study.convergence {
        // Taken before either procedure (`mesh_independent`).
        Convergence::MeshIndependent => {}
        Convergence::Divergent => {
            study.note = format!("{PROCEDURE}: the values diverge as the elements shrink (they span {}); no order, extrapolation or GCI: refine further, or look for an error that grows with refinement", span_text(phi));
        }
        Convergence::Oscillatory => {
            // Their oscillatory case: three times the data range.
            study.safety_factor = 3.0;
            study.gci_fine_pct = relative_pct(3.0 * range, phi[0]);
            study.note = format!("{PROCEDURE}: oscillatory convergence; no order or extrapolation, the GCI is three times the values' range, as they prescribe");
        }
        Convergence::Monotonic => {
            let fit = fit_power_law(h, phi);
            let at_edge = fit.order <= FIT_ORDERS.0 * 1.001 || fit.order >= FIT_ORDERS.1 * 0.999;
            if at_edge {
                study.note = format!("{PROCEDURE}: the fitted order {:.3} lies at the edge of {:?}: the sizes are not in the asymptotic range; no order, extrapolation or GCI", fit.order, FIT_ORDERS);
                return study;
            }
            study.order = Some(fit.order);
            study.extrapolated = Some(fit.phi0);
            study.e_ext_pct = relative_pct(fit.phi0 - phi[0], fit.phi0);
            study.gci_fine_pct = relative_pct(
                SAFETY_FACTOR * (fit.phi0 - phi[0]).abs() + fit.std_dev,
                phi[0],
            );
            study.note = format!(
                "{PROCEDURE}: monotonic convergence; the fit's standard deviation {:.3e} is added to 1.25 times the extrapolated error",
                fit.std_dev
            );
        }
    }
    study
}

struct PowerLawFit {
    phi0: f64,
    order: f64,
    /// `sqrt(sum of squared residuals / (n - 3))`.
    std_dev: f64,
}

/// For a given order the fit is linear in `phi0` and `alpha`; the order
/// minimising the squared residuals is found on a log grid, then by
/// golden-section search in the best cell.
fn fit_power_law(h: &[f64], phi: &[f64]) -> PowerLawFit {
    let residual = |order: f64| linear_fit(h, phi, order).2;
    let (low, high) = FIT_ORDERS;
    const STEPS: usize = 400;
    let at = |i: usize| low * (high / low).powf(i as f64 / STEPS as f64);
    let best = (0..=STEPS)
        .min_by(|&a, &b| residual(at(a)).total_cmp(&residual(at(b))))
        .unwrap_or(0);
    let (mut a, mut b) = (at(best.saturating_sub(1)), at((best + 1).min(STEPS)));
    let golden = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..200 {
        let (c, d) = (b - golden * (b - a), a + golden * (b - a));
        if residual(c) < residual(d) {
            b = d;
        } else {
            a = c;
        }
        if (b - a).abs() < 1e-13 * b {
            break;
        }
    }
    let order = (a + b) / 2.0;
    let (phi0, _, squares) = linear_fit(h, phi, order);
    let dof = phi.len().saturating_sub(3).max(1) as f64;
    PowerLawFit {
        phi0,
        order,
        std_dev: (squares / dof).sqrt(),
    }
}

/// `phi0`, `alpha` of `phi = phi0 + alpha h^p` by least squares, and the
/// sum of squared residuals.
fn linear_fit(h: &[f64], phi: &[f64], order: f64) -> (f64, f64, f64) {
    let n = h.len() as f64;
    let x: Vec<f64> = h.iter().map(|h| h.powf(order)).collect();
    let (sx, sy) = (x.iter().sum::<f64>(), phi.iter().sum::<f64>());
    let sxx: f64 = x.iter().map(|x| x * x).sum();
    let sxy: f64 = x.iter().zip(phi).map(|(x, y)| x * y).sum();
    let alpha = (n * sxy - sx * sy) / (n * sxx - sx * sx);
    let phi0 = (sy - alpha * sx) / n;
    let squares = x
        .iter()
        .zip(phi)
        .map(|(x, y)| (y - phi0 - alpha * x).powi(2))
        .sum();
    (phi0, alpha, squares)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `phi0 + a h^p`: every number has a closed form.
    fn power_law(phi0: f64, a: f64, p: f64, sizes: &[f64]) -> Vec<f64> {
        sizes.iter().map(|h| phi0 + a * h.powf(p)).collect()
    }

    #[test]
    fn three_grids_of_a_power_law_give_its_order_limit_and_closed_form_gci() {
        // Unequal ratios (1.5 and 1.6), so the order needs the iteration.
        for (phi0, a, p) in [(10.0, 2.0, 2.0), (-3.0, 0.7, 1.3), (100.0, -5.0, 0.8)] {
            let sizes = [0.5, 0.75, 1.2];
            let study = grid_convergence(&sizes, &power_law(phi0, a, p, &sizes)).unwrap();
            assert_eq!(study.convergence, Convergence::Monotonic);
            assert!((study.order.unwrap() - p).abs() < 1e-9, "{study:?}");
            assert!((study.extrapolated.unwrap() - phi0).abs() < 1e-9 * phi0.abs());
            let phi1 = phi0 + a * 0.5f64.powf(p);
            // GCI = 1.25 e_a / (r^p - 1) = 1.25 |a| h1^p / |phi1| here.
            let gci = 100.0 * 1.25 * a.abs() * 0.5f64.powf(p) / phi1.abs();
            assert!((study.gci_fine_pct.unwrap() - gci).abs() < 1e-8 * gci);
            let e_ext = 100.0 * (a * 0.5f64.powf(p) / phi0).abs();
            assert!((study.e_ext_pct.unwrap() - e_ext).abs() < 1e-8 * e_ext);
        }
    }

    #[test]
    fn a_coarser_size_has_its_own_larger_u_num() {
        let sizes = [0.1, 0.2, 0.4];
        let study = grid_convergence(&sizes, &power_law(1.0, 0.5, 2.0, &sizes)).unwrap();
        // |phi(h) - phi0| = 0.5 h^2; at the finest the GCI over 1.25 is that.
        for h in sizes {
            let u = study.standard_uncertainty_at(h).unwrap();
            assert!((u - 0.5 * h * h).abs() < 1e-12, "{h}: {u}");
        }
        assert_eq!(study.standard_uncertainty_at(0.3), None);
    }

    #[test]
    fn more_grids_fit_the_power_law_exactly() {
        let sizes = [0.09, 0.12, 0.18, 0.25, 0.33];
        let study = grid_convergence(&sizes, &power_law(7.5, -1.1, 1.7, &sizes)).unwrap();
        assert_eq!(study.convergence, Convergence::Monotonic);
        assert!((study.order.unwrap() - 1.7).abs() < 1e-6, "{study:?}");
        assert!((study.extrapolated.unwrap() - 7.5).abs() < 1e-8);
        let phi1 = 7.5 - 1.1 * 0.09f64.powf(1.7);
        let gci = 100.0 * 1.25 * 1.1 * 0.09f64.powf(1.7) / phi1;
        assert!((study.gci_fine_pct.unwrap() - gci).abs() < 1e-6 * gci);
    }

    #[test]
    fn oscillating_and_diverging_values_are_named_and_give_no_silent_number() {
        let oscillating = grid_convergence(&[1.0, 2.0, 4.0], &[5.0, 5.2, 4.6]).unwrap();
        assert_eq!(oscillating.convergence, Convergence::Oscillatory);
        assert!(oscillating.note.contains("oscillatory"));
        let diverging = grid_convergence(&[1.0, 2.0, 4.0], &[8.0, 6.0, 5.0]).unwrap();
        // Unequal ratios: a finer step that changes the value more than the
        // coarser one may still converge (here p = 1.55 fits), and a power
        // law with a negative order does not.
        let unequal = grid_convergence(&[0.25, 0.4, 0.5], &[4.656, 4.784, 4.885]).unwrap();
        assert_eq!(unequal.convergence, Convergence::Monotonic, "{unequal:?}");
        assert!((unequal.order.unwrap() - 1.55).abs() < 0.05, "{unequal:?}");
        let growing = [0.25, 0.4, 0.5].map(|h: f64| 1.0 + h.powf(-0.5));
        let growing = grid_convergence(&[0.25, 0.4, 0.5], &growing).unwrap();
        assert_eq!(growing.convergence, Convergence::Divergent, "{growing:?}");
        assert_eq!(diverging.convergence, Convergence::Divergent);
        assert_eq!(diverging.order, None);
        assert_eq!(diverging.gci_fine_pct, None);
        assert!(diverging.note.contains("diverge"));
        let four = grid_convergence(&[1.0, 2.0, 4.0, 8.0], &[5.0, 5.1, 4.9, 5.3]).unwrap();
        assert_eq!(four.convergence, Convergence::Oscillatory);
        assert_eq!(four.order, None);
    }

    /// Values that differ in their seventh digit only (a peak force of
    /// 7.459712 kN at three meshes, as a solver that does not resolve the
    /// neck prints it) are mesh-independent, whichever way the round-off
    /// points: no order, the finest value, the spread as u_num. A real
    /// mesh effect ten times the round-off limit is still studied.
    #[test]
    fn values_equal_within_round_off_are_mesh_independent() {
        for values in [
            [7.459712, 7.459714, 7.459711],
            [7.459712, 7.459711, 7.459713],
            [7.459712; 3],
        ] {
            let study = grid_convergence(&[0.25, 0.4, 0.5], &values).unwrap();
            assert_eq!(
                study.convergence,
                Convergence::MeshIndependent,
                "{values:?}"
            );
            assert_eq!(study.order, None);
            assert_eq!(study.extrapolated, Some(7.459712));
            let spread = values.iter().fold(f64::MIN, |a, &b| a.max(b))
                - values.iter().fold(f64::MAX, |a, &b| a.min(b));
            let u_num = study.standard_uncertainty().unwrap();
            assert!((u_num - spread).abs() < 1e-15, "{u_num} against {spread}");
            assert!(study.note.contains("round-off"), "{}", study.note);
        }
        let four =
            grid_convergence(&[0.1, 0.2, 0.4, 0.8], &[2.0, 2.0000005, 2.000001, 2.0]).unwrap();
        assert_eq!(four.convergence, Convergence::MeshIndependent);
        let studied = grid_convergence(&[0.25, 0.4, 0.5], &[7.4597, 7.4598, 7.4600]).unwrap();
        assert_ne!(studied.convergence, Convergence::MeshIndependent);
    }

    #[test]
    fn bad_input_is_refused_with_what_to_give() {
        assert!(grid_convergence(&[1.0, 2.0], &[1.0, 2.0])
            .unwrap_err()
            .contains("at least three"));
        assert!(grid_convergence(&[1.0, 1.0, 2.0], &[1.0, 2.0, 3.0])
            .unwrap_err()
            .contains("equal"));
        assert!(grid_convergence(&[1.0, -2.0, 3.0], &[1.0, 2.0, 3.0])
            .unwrap_err()
            .contains("positive"));
        assert!(grid_convergence(&[1.0, 2.0, 3.0], &[1.0, f64::NAN, 3.0])
            .unwrap_err()
            .contains("finite"));
    }
}
