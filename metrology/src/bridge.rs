//! Wheatstone bridges of strain gauges: the strain a shunt resistor
//! simulates, and the gain correction a shunt check gives.
//!
//! # The bridge and its numbering
//!
//! Four arms of resistance `R_i = R (1 + x_i)`, equal (`R`) and balanced
//! before any change, `x_i = dR_i / R` the arm's relative change. Arms 1
//! and 2 form one divider, meeting at output node A; arms 4 and 3 the
//! other, meeting at node B; arms 1 and 4 go to the excitation's 0 V,
//! arms 2 and 3 to `+V_ex`:
//!
//! ```text
//! V_out / V_ex = R1 / (R1 + R2) - R4 / (R3 + R4)
//!              = (1 + x1) / (2 + x1 + x2) - (1 + x4) / (2 + x3 + x4)   (exact)
//!              ~ (x1 - x2 + x3 - x4) / 4                               (linearised)
//! ```
//!
//! so a rise in arm 1 or 3 raises the output and a rise in arm 2 or 4
//! lowers it: arms 1 and 3 count positive, 2 and 4 negative (the rule
//! `eps1 - eps2 + eps3 - eps4` of the strain-gauge textbooks, e.g.
//! Hoffmann, *An Introduction to Measurements using Strain Gages*, HBM).
//! NI-DAQmx draws the same bridge with other labels (its quarter-bridge
//! gauge is its "R4"); only the signs above matter here.
//!
//! # The channel's reading
//!
//! A channel measures `V_out / V_ex` less its value at the zero (the
//! balanced bridge gives 0) and turns it into strain in one of two ways,
//! [`StrainConversion`]: linearly, `eps = 4 (V_out / V_ex) / (GF k)` with
//! `k` the bridge factor, or by inverting the bridge type's own exact law
//! (NI-DAQmx's strain equations do). For the configurations here the
//! exact law for a strain `eps` (`u = GF eps`) is
//!
//! ```text
//! V_out / V_ex = k u / (4 + 2 s u)
//! ```
//!
//! with `k` [`BridgeType::bridge_factor`] and `s` the sum of arms 1 and
//! 2's relative changes per `u` ([`BridgeType::nonlinearity`]): `s = 0`
//! makes the bridge linear (the bending bridges), `s = 1` is the quarter
//! bridge's `u / (4 + 2 u)`.
//!
//! # A shunt
//!
//! A resistor `R_s` across an arm of resistance `R_g` makes it
//! `R_g R_s / (R_g + R_s)`: `x = -R_g / (R_g + R_s)`, the only change in
//! the bridge, whatever its type. Its output is exactly
//! `sign(arm) x / (4 + 2 x)` — the quarter bridge's non-linearity, even in
//! a bridge that is linear for real strain, since one arm alone changes.
//! The widely quoted formula `eps_sim = -R_g / (GF (R_g + R_s))` (Vishay
//! Micro-Measurements TN-514, eq. 514.6) is `x / GF`: the strain that
//! would change the gauge as much as the shunt does. A channel that
//! inverts the quarter bridge's law reads exactly that (shunt across arm
//! 1); a linear channel reads `x / ((1 + x/2) GF k)` (across arm 1 or 3;
//! arms 2 and 4 change its sign), larger in size than the quoted `x / (GF
//! k)` by the factor `1 / (1 + x/2)` (0.17 % for 350 ohm and 100 kohm).
//! TN-514's section on non-linearity treats the same difference.

use crate::budget::{rectangular, Budget, Contribution};

/// Why a bridge's arithmetic has no answer; each message says what to fix.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum BridgeError {
    #[error("the {what} is {value}; give a finite number")]
    NotFinite { what: &'static str, value: f64 },
    #[error("the {what} is {ohm} ohm; a resistance must be above 0")]
    NonPositiveResistance { what: &'static str, ohm: f64 },
    #[error("the gauge factor is {0}; give a number above 0 (about 2 for metal foil gauges)")]
    GaugeFactor(f64),
    #[error("Poisson's ratio is {0}; give a number above 0 and at most 0.5 (about 0.3 for steel and aluminium)")]
    PoissonRatio(f64),
    #[error("arm {arm}'s relative change is {relative_change}; its resistance R (1 + dR/R) must stay above 0, so give a change above -1")]
    ArmResistance { arm: usize, relative_change: f64 },
    #[error("the {what} is {pct} %; give a tolerance of at least 0 and below 100 %")]
    Tolerance { what: &'static str, pct: f64 },
    #[error("the measured step's standard error is {0}; give a number of at least 0")]
    StandardError(f64),
    #[error("the measured step's degrees of freedom are {0}; give a number above 0, or none for infinite")]
    DegreesOfFreedom(f64),
    #[error("a {shunt_ohm} ohm shunt across a {gauge_ohm} ohm arm shorts it (to the precision of a double); a shunt check needs a shunt far larger than the arm")]
    ShuntShortsArm { gauge_ohm: f64, shunt_ohm: f64 },
    #[error("an output of {output_ratio} V/V is more than this bridge type gives for any strain; check the bridge type and the wiring")]
    OutputBeyondBridge { output_ratio: f64 },
    #[error("the {what} is not a finite number for these inputs: {why}")]
    NoFiniteResult {
        what: &'static str,
        why: &'static str,
    },
}

/// The common configurations of strain gauges in a bridge, with NI's
/// names ("quarter-bridge I" ...) for the same wiring. Active gauges sit
/// in arm 1, then arm 2 (the one sharing its output node), then 3 and 4;
/// the others are completion resistors, which do not change.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BridgeType {
    /// One active gauge (arm 1). NI quarter-bridge I; quarter-bridge II
    /// adds a dummy gauge for temperature, which gives the same output.
    Quarter,
    /// Two active gauges in adjacent arms (1 and 2) at opposite strains,
    /// `+eps` and `-eps` (the two faces of a bent beam). NI half-bridge II.
    HalfBending,
    /// One axial gauge (arm 1) and one transverse gauge (arm 2) that sees
    /// `-nu eps`. NI half-bridge I.
    HalfPoisson { poisson_ratio: f64 },
    /// Four active gauges, `+eps` in arms 1 and 3, `-eps` in 2 and 4.
    /// NI full-bridge I.
    FullBending,
    /// Two axial gauges (arms 1 and 3) and two transverse ones (arms 2 and
    /// 4) at `-nu eps`. NI full-bridge III.
    FullPoisson { poisson_ratio: f64 },
}

impl BridgeType {
    /// The Poisson ratio must be in (0, 0.5]: above 0.5 a material would
    /// grow in volume under tension, and at 0 the transverse gauges would
    /// add nothing (use the quarter or half-bending type).
    pub fn check(&self) -> Result<(), BridgeError> {
        match *self {
            BridgeType::HalfPoisson { poisson_ratio }
            | BridgeType::FullPoisson { poisson_ratio } => {
                if poisson_ratio > 0.0 && poisson_ratio <= 0.5 {
                    Ok(())
                } else {
                    Err(BridgeError::PoissonRatio(poisson_ratio))
                }
            }
            _ => Ok(()),
        }
    }

    /// Each arm's relative change per unit of `GF eps` (the strain a
    /// channel reports, times the gauge factor): `+1` an axial gauge,
    /// `-1` a gauge at the opposite strain, `-nu` a transverse gauge, 0 a
    /// completion resistor.
    pub fn arm_pattern(&self) -> Result<[f64; 4], BridgeError> {
        self.check()?;
        Ok(match *self {
            BridgeType::Quarter => [1.0, 0.0, 0.0, 0.0],
            BridgeType::HalfBending => [1.0, -1.0, 0.0, 0.0],
            BridgeType::HalfPoisson { poisson_ratio } => [1.0, -poisson_ratio, 0.0, 0.0],
            BridgeType::FullBending => [1.0, -1.0, 1.0, -1.0],
            BridgeType::FullPoisson { poisson_ratio } => [1.0, -poisson_ratio, 1.0, -poisson_ratio],
        })
    }

    /// Output per unit strain relative to a quarter bridge (the linearised
    /// `x1 - x2 + x3 - x4` of [`BridgeType::arm_pattern`]): 1, 2, `1 + nu`,
    /// 4, `2 (1 + nu)`.
    pub fn bridge_factor(&self) -> Result<f64, BridgeError> {
        let [a1, a2, a3, a4] = self.arm_pattern()?;
        Ok(a1 - a2 + a3 - a4)
    }

    /// `s` of the exact law `V_out / V_ex = k u / (4 + 2 s u)`: arms 1 and
    /// 2's relative changes summed, per `u = GF eps` (1, 0, `1 - nu`, 0,
    /// `1 - nu`). Where both arms of a divider change equally and
    /// oppositely (`s = 0`) the divider's ratio is exactly linear.
    pub fn nonlinearity(&self) -> Result<f64, BridgeError> {
        let [a1, a2, _, _] = self.arm_pattern()?;
        Ok(a1 + a2)
    }

    /// The four arms' relative changes under a strain `strain` read with
    /// gauge factor `gauge_factor`, for [`bridge_output_ratio`].
    pub fn relative_changes(
        &self,
        strain: f64,
        gauge_factor: f64,
    ) -> Result<[f64; 4], BridgeError> {
        finite("strain", strain)?;
        check_gauge_factor(gauge_factor)?;
        let u = finite_result(
            "gauge factor times strain",
            gauge_factor * strain,
            "a strain or gauge factor too large",
        )?;
        Ok(self.arm_pattern()?.map(|a| a * u))
    }
}

/// One arm of the bridge (see the module's numbering).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BridgeArm {
    R1,
    R2,
    R3,
    R4,
}

impl BridgeArm {
    pub const ALL: [BridgeArm; 4] = [BridgeArm::R1, BridgeArm::R2, BridgeArm::R3, BridgeArm::R4];

    /// How the arm's change counts in the output: `+1` for arms 1 and 3,
    /// `-1` for 2 and 4.
    pub fn sign(self) -> f64 {
        match self {
            BridgeArm::R1 | BridgeArm::R3 => 1.0,
            BridgeArm::R2 | BridgeArm::R4 => -1.0,
        }
    }

    fn index(self) -> usize {
        match self {
            BridgeArm::R1 => 0,
            BridgeArm::R2 => 1,
            BridgeArm::R3 => 2,
            BridgeArm::R4 => 3,
        }
    }
}

/// How a channel turns `V_out / V_ex` (its change since the zero) into
/// strain. Which one a DAQ uses decides the strain a shunt shows, so the
/// shunt check must be told.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StrainConversion {
    /// `eps = 4 (V_out / V_ex) / (GF k)`: a span in mV/V per um/m, the
    /// bridge's non-linearity left in the reading.
    Linear,
    /// The bridge type's exact law inverted, `eps = 4 r / (GF (k - 2 s r))`
    /// for `r = V_out / V_ex`: a real strain is read without non-linearity
    /// (NI-DAQmx's strain equations for its bridge configurations).
    InverseOfBridgeLaw,
}

impl StrainConversion {
    /// The strain a channel of `bridge` type reports for an output ratio
    /// `output_ratio` (`V_out / V_ex` less its zero).
    pub fn strain(
        self,
        bridge: BridgeType,
        output_ratio: f64,
        gauge_factor: f64,
    ) -> Result<f64, BridgeError> {
        finite("bridge output ratio", output_ratio)?;
        check_gauge_factor(gauge_factor)?;
        let strain =
            4.0 * output_ratio / (gauge_factor * self.denominator(bridge, output_ratio)?);
        finite_result(
            "strain",
            strain,
            "an output the bridge type cannot give, or a gauge factor near 0",
        )
    }

    /// `d eps / d r`: how much the reported strain moves per unit of the
    /// output ratio at `output_ratio`.
    fn strain_per_output(
        self,
        bridge: BridgeType,
        output_ratio: f64,
        gauge_factor: f64,
    ) -> Result<f64, BridgeError> {
        let k = bridge.bridge_factor()?;
        let d = self.denominator(bridge, output_ratio)?;
        // d/dr [4 r / (GF d(r))] with d = k - 2 s r: 4 k / (GF d^2);
        // linear: d = k, 4 / (GF k) = 4 k / (GF k^2).
        Ok(4.0 * k / (gauge_factor * d * d))
    }

    /// `k` (linear) or `k - 2 s r` (the inverse of the exact law), which
    /// is above 0 for every output a strain can give (`|r| < 1/2`).
    fn denominator(self, bridge: BridgeType, output_ratio: f64) -> Result<f64, BridgeError> {
        let k = bridge.bridge_factor()?;
        let denominator = match self {
            StrainConversion::Linear => k,
            StrainConversion::InverseOfBridgeLaw => k - 2.0 * bridge.nonlinearity()? * output_ratio,
        };
        if denominator > 0.0 {
            Ok(denominator)
        } else {
            Err(BridgeError::OutputBeyondBridge { output_ratio })
        }
    }
}

/// The relative change `dR / R = -R_g / (R_g + R_s)` of an arm of
/// resistance `gauge_ohm` when `shunt_ohm` is put across it (the parallel
/// resistance is `R_g R_s / (R_g + R_s)`). In (-1, 0).
pub fn shunt_relative_change(gauge_ohm: f64, shunt_ohm: f64) -> Result<f64, BridgeError> {
    check_resistance("gauge resistance", gauge_ohm)?;
    check_resistance("shunt resistance", shunt_ohm)?;
    // -1 / (1 + R_s / R_g): no overflow of R_g + R_s.
    let change = -1.0 / (1.0 + shunt_ohm / gauge_ohm);
    if change > -1.0 {
        Ok(change)
    } else {
        Err(BridgeError::ShuntShortsArm {
            gauge_ohm,
            shunt_ohm,
        })
    }
}

/// `V_out / V_ex` of a bridge of equal arms, balanced before the changes,
/// for the arms' relative changes `dR_i / R` (arms 1 to 4 in the module's
/// numbering: 1 and 3 count positive, 2 and 4 negative). Exact:
/// `(1 + x1) / (2 + x1 + x2) - (1 + x4) / (2 + x3 + x4)`, computed as
/// `(x1 - x2) / (2 (2 + x1 + x2)) + (x3 - x4) / (2 (2 + x3 + x4))`.
pub fn bridge_output_ratio(relative_changes: [f64; 4]) -> Result<f64, BridgeError> {
    for (i, &x) in relative_changes.iter().enumerate() {
        finite("arm's relative change", x)?;
        if x <= -1.0 {
            return Err(BridgeError::ArmResistance {
                arm: i + 1,
                relative_change: x,
            });
        }
    }
    let [x1, x2, x3, x4] = relative_changes;
    // Each divider less its balanced 1/2, so that no two near-equal
    // halves are subtracted (that would lose digits for small changes):
    // (1 + x1) / (2 + x1 + x2) - 1/2 = (x1 - x2) / (2 (2 + x1 + x2)); the
    // arms' sum first, so that equal and opposite changes leave exactly 2.
    let ratio = (x1 - x2) / (2.0 * (2.0 + (x1 + x2))) + (x3 - x4) / (2.0 * (2.0 + (x3 + x4)));
    finite_result("bridge output ratio", ratio, "an arm's change too large")
}

/// The strain a channel of `bridge` type shows when `shunt_ohm` is put
/// across `arm` (resistance `gauge_ohm`, as every arm), read with
/// `gauge_factor` and `conversion`: the bridge's exact output for the
/// shunt's change `x` (see [`shunt_relative_change`]), converted as the
/// channel converts it. Linear: `sign x / ((1 + x/2) GF k)`; inverse of
/// the law: `4 r / (GF (k - 2 s r))` with `r = sign x / (4 + 2 x)`, which
/// for a quarter bridge shunted across arm 1 is exactly `x / GF`.
pub fn expected_shunt_strain(
    bridge: BridgeType,
    gauge_ohm: f64,
    shunt_ohm: f64,
    gauge_factor: f64,
    arm: BridgeArm,
    conversion: StrainConversion,
) -> Result<f64, BridgeError> {
    conversion.strain(
        bridge,
        shunt_output_ratio(gauge_ohm, shunt_ohm, arm)?,
        gauge_factor,
    )
}

/// The bridge's output with the shunt across `arm` and nothing else.
fn shunt_output_ratio(gauge_ohm: f64, shunt_ohm: f64, arm: BridgeArm) -> Result<f64, BridgeError> {
    let mut changes = [0.0; 4];
    changes[arm.index()] = shunt_relative_change(gauge_ohm, shunt_ohm)?;
    bridge_output_ratio(changes)
}

/// A shunt check: a known resistor across one arm, the channel's step in
/// strain when it is switched in, and what that step should be.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShuntCheck {
    pub bridge: BridgeType,
    pub conversion: StrainConversion,
    /// The arm the shunt is across.
    pub arm: BridgeArm,
    /// The arm's resistance as the shunt sees it (the gauge's, plus its
    /// leads where the shunt is switched in at the instrument).
    pub gauge_ohm: f64,
    /// The gauge resistance's tolerance, `+-%` (rectangular).
    pub gauge_tolerance_pct: f64,
    pub shunt_ohm: f64,
    /// The shunt resistor's tolerance, `+-%` (rectangular).
    pub shunt_tolerance_pct: f64,
    /// The gauge factor the channel is set to. The correction does not
    /// depend on it (the expected and the measured steps both scale as
    /// `1 / GF`); its own tolerance stays a span error of the strain.
    pub gauge_factor: f64,
    /// The channel's step when the shunt is switched in (strain, m/m).
    pub measured_strain: f64,
    /// The step's standard error (strain, m/m), from the scatter of the
    /// readings with and without the shunt.
    pub measured_standard_error_strain: f64,
    /// Degrees of freedom of that standard error; `None` is infinite.
    pub measured_dof: Option<f64>,
}

/// What a shunt check gives: multiply the channel's strain by `factor`.
/// Its uncertainty is the same in every reading it corrects (a span
/// error of the channel): a budget that uses it should mark it shared by
/// the channel ([`Contribution::shared_by`]).
#[derive(Clone, Debug, PartialEq)]
pub struct GainCorrection {
    /// `expected / measured`.
    pub factor: f64,
    pub standard_uncertainty: f64,
    pub budget: Budget,
}

/// Why a shunt check gives no correction.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ShuntError {
    #[error(transparent)]
    Input(#[from] BridgeError),
    #[error("the tolerance of the shunt check is {0} %; give a number above 0 and below 100")]
    Tolerance(f64),
    #[error("the shunt simulates {0} strain, too small a step to compare a reading with; use a smaller shunt resistor")]
    NoExpectedStep(f64),
    #[error("the channel's step is {:.1} um/m where the shunt simulates {:.1} um/m ({:+.2} %), beyond the {tolerance_pct} % tolerance: {hint}; correcting the gain would hide the fault", .measured_strain * 1e6, .expected_strain * 1e6, (.measured_strain / .expected_strain - 1.0) * 100.0)]
    OutOfTolerance {
        expected_strain: f64,
        measured_strain: f64,
        tolerance_pct: f64,
        hint: &'static str,
    },
}

impl ShuntCheck {
    /// The step the channel should show ([`expected_shunt_strain`]).
    pub fn expected_strain(&self) -> Result<f64, BridgeError> {
        self.inputs_checked()?;
        expected_shunt_strain(
            self.bridge,
            self.gauge_ohm,
            self.shunt_ohm,
            self.gauge_factor,
            self.arm,
            self.conversion,
        )
    }

    /// The expected step's budget (strain): the shunt's and the gauge's
    /// tolerances, rectangular, each with its sensitivity
    /// `d eps / dR = d eps / dr * dr / dx * dx / dR`, where `x = -R_g /
    /// (R_g + R_s)` gives `dx / dR_s = -x (1 + x) / R_s` and
    /// `dx / dR_g = x (1 + x) / R_g`, and `r = sign x / (4 + 2 x)` gives
    /// `dr / dx = 4 sign / (4 + 2 x)^2`. Only the shunted arm's resistance
    /// enters to first order: the other arms move the divider's slope by
    /// the square of their mismatch.
    pub fn expected_budget(&self) -> Result<Budget, BridgeError> {
        self.inputs_checked()?;
        let x = shunt_relative_change(self.gauge_ohm, self.shunt_ohm)?;
        let ratio = shunt_output_ratio(self.gauge_ohm, self.shunt_ohm, self.arm)?;
        let strain_per_x =
            self.conversion
                .strain_per_output(self.bridge, ratio, self.gauge_factor)?
                * 4.0
                * self.arm.sign()
                / (4.0 + 2.0 * x).powi(2);
        let tolerance = |ohm: f64, pct: f64| rectangular(ohm * pct / 100.0);
        let part = |source: &str, u: f64, x_per_ohm: f64| Contribution {
            sensitivity: strain_per_x * x_per_ohm,
            ..Contribution::direct(source, u, None)
        };
        Ok(Budget {
            contributions: vec![
                part(
                    "shunt resistor tolerance",
                    tolerance(self.shunt_ohm, self.shunt_tolerance_pct),
                    -x * (1.0 + x) / self.shunt_ohm,
                ),
                part(
                    "gauge resistance tolerance",
                    tolerance(self.gauge_ohm, self.gauge_tolerance_pct),
                    x * (1.0 + x) / self.gauge_ohm,
                ),
            ],
        })
    }

    /// The factor `expected / measured`'s budget: the expected step's
    /// parts divided by the measured step, and the measured step's
    /// standard error with sensitivity `-expected / measured^2`.
    pub fn factor_budget(&self) -> Result<Budget, BridgeError> {
        let expected = self.expected_strain()?;
        let measured = self.measured_strain;
        let mut budget = self.expected_budget()?;
        for part in &mut budget.contributions {
            part.sensitivity /= measured;
        }
        budget.contributions.push(Contribution {
            sensitivity: -expected / (measured * measured),
            ..Contribution::direct(
                "measured step",
                self.measured_standard_error_strain,
                self.measured_dof,
            )
        });
        Ok(budget)
    }

    /// The gain correction, refused when the measured step is off the
    /// expected one by more than `tolerance_pct` (`|measured / expected -
    /// 1|`): so large a difference is a fault to find, not a gain to
    /// correct.
    pub fn gain_correction(&self, tolerance_pct: f64) -> Result<GainCorrection, ShuntError> {
        if !(tolerance_pct > 0.0 && tolerance_pct < 100.0) {
            return Err(ShuntError::Tolerance(tolerance_pct));
        }
        let expected = self.expected_strain()?;
        let measured = self.measured_strain;
        let ratio = measured / expected;
        if expected == 0.0 || !ratio.is_finite() {
            return Err(ShuntError::NoExpectedStep(expected));
        }
        if (ratio - 1.0).abs() > tolerance_pct / 100.0 {
            return Err(ShuntError::OutOfTolerance {
                expected_strain: expected,
                measured_strain: measured,
                tolerance_pct,
                hint: if ratio < 0.0 {
                    "the step has the wrong sign: check which arm the shunt is across and the polarity of the excitation and the output leads"
                } else {
                    "check the wiring (the arm shunted, lead resistance, sense leads), the gauge factor entered and the bridge type configured"
                },
            });
        }
        let budget = self.factor_budget()?;
        let standard_uncertainty = finite_result(
            "gain correction's standard uncertainty",
            budget.combined(),
            "resistances or uncertainties at the edge of what a double can hold",
        )?;
        Ok(GainCorrection {
            factor: expected / measured,
            standard_uncertainty,
            budget,
        })
    }

    fn inputs_checked(&self) -> Result<(), BridgeError> {
        self.bridge.check()?;
        check_resistance("gauge resistance", self.gauge_ohm)?;
        check_resistance("shunt resistance", self.shunt_ohm)?;
        check_gauge_factor(self.gauge_factor)?;
        for (what, pct) in [
            ("gauge resistance tolerance", self.gauge_tolerance_pct),
            ("shunt resistor tolerance", self.shunt_tolerance_pct),
        ] {
            if !(0.0..100.0).contains(&pct) {
                return Err(BridgeError::Tolerance { what, pct });
            }
        }
        finite("measured step", self.measured_strain)?;
        let se = self.measured_standard_error_strain;
        if !(se >= 0.0 && se.is_finite()) {
            return Err(BridgeError::StandardError(se));
        }
        match self.measured_dof {
            Some(dof) if dof.is_nan() || dof <= 0.0 => Err(BridgeError::DegreesOfFreedom(dof)),
            _ => Ok(()),
        }
    }
}

fn finite(what: &'static str, value: f64) -> Result<f64, BridgeError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(BridgeError::NotFinite { what, value })
    }
}

fn finite_result(what: &'static str, value: f64, why: &'static str) -> Result<f64, BridgeError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(BridgeError::NoFiniteResult { what, why })
    }
}

fn check_resistance(what: &'static str, ohm: f64) -> Result<(), BridgeError> {
    finite(what, ohm)?;
    if ohm > 0.0 {
        Ok(())
    } else {
        Err(BridgeError::NonPositiveResistance { what, ohm })
    }
}

fn check_gauge_factor(gauge_factor: f64) -> Result<(), BridgeError> {
    if gauge_factor > 0.0 && gauge_factor.is_finite() {
        Ok(())
    } else {
        Err(BridgeError::GaugeFactor(gauge_factor))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::monte_carlo::{propagate, InputDistribution};
    use proptest::prelude::*;

    const NU: f64 = 0.3;
    const ALL_TYPES: [BridgeType; 5] = [
        BridgeType::Quarter,
        BridgeType::HalfBending,
        BridgeType::HalfPoisson { poisson_ratio: NU },
        BridgeType::FullBending,
        BridgeType::FullPoisson { poisson_ratio: NU },
    ];

    fn assert_relative(actual: f64, expected: f64, tolerance: f64) {
        assert!(
            ((actual - expected) / expected).abs() < tolerance,
            "{actual} vs {expected}"
        );
    }

    fn shunt_strain(bridge: BridgeType, arm: BridgeArm, conversion: StrainConversion) -> f64 {
        expected_shunt_strain(bridge, 350.0, 100e3, 2.0, arm, conversion).unwrap()
    }

    /// 350 ohm gauge, GF 2, 100 kohm across the active gauge (arm 1):
    /// x = dR/R = -350 / 100350 = -3.4878e-3. The widely quoted formula
    /// (TN-514 eq. 514.6) is x / GF = -1743.896 um/m. The bridge's exact
    /// output is r = x / (4 + 2x); a linear channel reads 4 r / GF =
    /// x / ((1 + x/2) GF) = -1746.943 um/m, 0.1747 % more in size than the
    /// formula (the non-linearity, about -x/2, under 0.2 % here); a channel
    /// inverting the quarter bridge's law reads x / GF exactly.
    #[test]
    fn a_quarter_bridge_shows_the_hand_formulas() {
        let x = -350.0 / 100350.0;
        assert_relative(shunt_relative_change(350.0, 100e3).unwrap(), x, 1e-15);
        let quoted = -350.0 / (2.0 * (350.0 + 100e3));
        assert_relative(quoted * 1e6, -1_743.896_362_730_443, 1e-12);
        let exact_output = x / (4.0 + 2.0 * x);
        let linear_reading = 4.0 * exact_output / 2.0;
        assert_relative(linear_reading * 1e6, -1_746.942_850_012_478, 1e-12);
        assert_relative(
            linear_reading / quoted - 1.0,
            0.001_746_942_850_012_478,
            1e-9,
        );
        assert!((linear_reading / quoted - 1.0) < 0.002);

        let quarter = |arm, conversion| shunt_strain(BridgeType::Quarter, arm, conversion);
        use StrainConversion::{InverseOfBridgeLaw, Linear};
        assert_relative(quarter(BridgeArm::R1, Linear), linear_reading, 1e-12);
        assert_relative(quarter(BridgeArm::R1, InverseOfBridgeLaw), quoted, 1e-12);
        // Across a completion resistor of the negative side (arm 2 or 4)
        // the step is positive, the same size for a linear channel.
        assert_relative(quarter(BridgeArm::R2, Linear), -linear_reading, 1e-12);
        assert_relative(quarter(BridgeArm::R3, Linear), linear_reading, 1e-12);
        assert_relative(quarter(BridgeArm::R4, Linear), -linear_reading, 1e-12);
        // Inverting the law at r = -x / (4 + 2x): 4 r / (GF (1 - 2 r)) =
        // -x / (GF (1 + x)).
        assert_relative(
            quarter(BridgeArm::R2, InverseOfBridgeLaw),
            -x / (2.0 * (1.0 + x)),
            1e-12,
        );
    }

    /// The same shunt across one arm of a half or full bridge changes the
    /// output exactly as in a quarter bridge; the channel divides by the
    /// bridge factor k: linear, x / ((1 + x/2) GF k). Inverting the law,
    /// 4 r / (GF (k - 2 s r)): the same for the bending bridges (s = 0);
    /// for the Poisson ones (nu = 0.3, s = 0.7) a little smaller in size.
    #[test]
    fn half_and_full_bridges_show_the_quarter_step_over_the_bridge_factor() {
        let x = -350.0 / 100350.0;
        let r = x / (4.0 + 2.0 * x);
        let linear = |k: f64| 4.0 * r / (2.0 * k);
        let inverse = |k: f64, s: f64| 4.0 * r / (2.0 * (k - 2.0 * s * r));
        use StrainConversion::{InverseOfBridgeLaw, Linear};
        let cases = [
            (BridgeType::HalfBending, 2.0, 0.0, -873.471_425_006_239_1),
            (BridgeType::FullBending, 4.0, 0.0, -436.735_712_503_119_5),
            (ALL_TYPES[2], 1.3, 0.7, -1_343.802_192_317_291),
            (ALL_TYPES[4], 2.6, 0.7, -671.901_096_158_645_5),
        ];
        for (bridge, k, s, linear_um_per_m) in cases {
            let reading = shunt_strain(bridge, BridgeArm::R1, Linear);
            assert_relative(reading, linear(k), 1e-12);
            assert_relative(reading * 1e6, linear_um_per_m, 1e-12);
            let inverted = shunt_strain(bridge, BridgeArm::R1, InverseOfBridgeLaw);
            assert_relative(inverted, inverse(k, s), 1e-12);
        }
        assert_relative(
            shunt_strain(ALL_TYPES[2], BridgeArm::R1, InverseOfBridgeLaw) * 1e6,
            -1_342.539_317_222_861,
            1e-12,
        );
        assert_relative(
            shunt_strain(ALL_TYPES[4], BridgeArm::R1, InverseOfBridgeLaw) * 1e6,
            -671.585_228_962_592_7,
            1e-12,
        );
    }

    #[test]
    fn bridge_factors_are_the_configurations() {
        let by_hand = [1.0, 2.0, 1.0 + NU, 4.0, 2.0 * (1.0 + NU)];
        for (bridge, factor) in ALL_TYPES.iter().zip(by_hand) {
            assert_relative(bridge.bridge_factor().unwrap(), factor, 1e-15);
        }
    }

    /// Equal and opposite changes in the two arms of one divider leave its
    /// total unchanged: (1 + x) / 2 - 1/2 = x / 2, exactly linear, for any
    /// x (to the last bit: 2x / 4 has no rounding); a quarter bridge's
    /// x / (4 + 2x) is not, 1/1.05 of linear at x = 0.1.
    #[test]
    fn equal_and_opposite_changes_in_adjacent_arms_are_exactly_linear() {
        for x in [1e-6, -2e-3, 0.05, -0.3, 0.9] {
            let half = bridge_output_ratio([x, -x, 0.0, 0.0]).unwrap();
            assert_eq!(half, x / 2.0, "{x}");
            let full = bridge_output_ratio([x, -x, x, -x]).unwrap();
            assert_eq!(full, x, "{x}");
            let quarter = bridge_output_ratio([x, 0.0, 0.0, 0.0]).unwrap();
            assert_relative(quarter, x / (4.0 + 2.0 * x), 1e-12);
        }
        assert_relative(
            bridge_output_ratio([0.1, 0.0, 0.0, 0.0]).unwrap() / 0.025,
            1.0 / 1.05,
            1e-12,
        );
    }

    /// Every type's exact output is k u / (4 + 2 s u) (u = GF eps), and
    /// NI's strain equations invert it: quarter eps = 4 r / (GF (1 - 2 r)),
    /// half Poisson 4 r / (GF ((1 + nu) - 2 r (1 - nu))), full Poisson
    /// 2 r / (GF ((1 + nu) - r (1 - nu))) (NI's with r -> -r, their sign).
    #[test]
    fn each_type_follows_its_exact_law_and_the_inverse_reads_real_strain() {
        for bridge in ALL_TYPES {
            let k = bridge.bridge_factor().unwrap();
            let s = bridge.nonlinearity().unwrap();
            for strain in [-0.02, -1e-3, 1e-6, 5e-3, 0.05] {
                let u = 2.1 * strain;
                let changes = bridge.relative_changes(strain, 2.1).unwrap();
                let r = bridge_output_ratio(changes).unwrap();
                assert_relative(r, k * u / (4.0 + 2.0 * s * u), 1e-12);
                let read = StrainConversion::InverseOfBridgeLaw
                    .strain(bridge, r, 2.1)
                    .unwrap();
                assert_relative(read, strain, 1e-12);
                let ni = match bridge {
                    BridgeType::Quarter => 4.0 * r / (2.1 * (1.0 - 2.0 * r)),
                    BridgeType::HalfPoisson { .. } => {
                        4.0 * r / (2.1 * ((1.0 + NU) - 2.0 * r * (1.0 - NU)))
                    }
                    BridgeType::FullPoisson { .. } => {
                        2.0 * r / (2.1 * ((1.0 + NU) - r * (1.0 - NU)))
                    }
                    BridgeType::HalfBending => 2.0 * r / 2.1,
                    BridgeType::FullBending => r / 2.1,
                };
                assert_relative(read, ni, 1e-12);
            }
        }
    }

    fn check(bridge: BridgeType, conversion: StrainConversion, measured_scale: f64) -> ShuntCheck {
        let mut check = ShuntCheck {
            bridge,
            conversion,
            arm: BridgeArm::R1,
            gauge_ohm: 350.0,
            gauge_tolerance_pct: 0.3,
            shunt_ohm: 100e3,
            shunt_tolerance_pct: 0.1,
            gauge_factor: 2.05,
            measured_strain: 0.0,
            measured_standard_error_strain: 1e-6,
            measured_dof: Some(19.0),
        };
        check.measured_strain = measured_scale * check.expected_strain().unwrap();
        check
    }

    #[test]
    fn the_correction_is_expected_over_measured_with_three_parts() {
        let check = check(BridgeType::Quarter, StrainConversion::Linear, 0.99);
        let correction = check.gain_correction(2.0).unwrap();
        assert_relative(correction.factor, 1.0 / 0.99, 1e-12);
        let sources: Vec<&str> = correction
            .budget
            .contributions
            .iter()
            .map(|c| c.source.as_str())
            .collect();
        assert_eq!(
            sources,
            [
                "shunt resistor tolerance",
                "gauge resistance tolerance",
                "measured step"
            ]
        );
        assert_eq!(
            correction.standard_uncertainty,
            correction.budget.combined()
        );
        // The gauge's tolerance, 0.3 % / sqrt(3) of R_g, moves x by
        // (1 + x) of that: about 0.173 % of the factor.
        let gauge = correction.budget.contributions[1].in_result();
        assert_relative(
            gauge,
            correction.factor * 0.003 / 3f64.sqrt() * (1.0 - 350.0 / 100350.0)
                / (1.0 - 350.0 / 100350.0 / 2.0),
            1e-9,
        );
        // The expected step's own uncertainty, in strain.
        let expected = check.expected_budget().unwrap();
        assert_eq!(expected.contributions.len(), 2);
        assert!(expected.combined() > 0.0 && expected.combined() < 1e-5);
    }

    /// The first-order law against GUM Supplement 1 on the factor
    /// expected / measured, with tolerances and a standard error large
    /// enough for each part to count.
    #[test]
    fn the_factors_uncertainty_agrees_with_monte_carlo() {
        let configurations = [
            (BridgeType::Quarter, StrainConversion::Linear, BridgeArm::R1),
            (
                ALL_TYPES[2],
                StrainConversion::InverseOfBridgeLaw,
                BridgeArm::R2,
            ),
        ];
        for (bridge, conversion, arm) in configurations {
            let mut check = check(bridge, conversion, 1.02);
            check.arm = arm;
            check.gauge_tolerance_pct = 1.0;
            check.shunt_tolerance_pct = 2.0;
            let expected = check.expected_strain().unwrap();
            check.measured_strain = 1.02 * expected;
            check.measured_standard_error_strain = 0.01 * expected.abs();
            check.measured_dof = None;
            let law = check.gain_correction(5.0).unwrap();
            let inputs = [
                InputDistribution::Rectangular {
                    mean: check.gauge_ohm,
                    half_width: 0.01 * check.gauge_ohm,
                },
                InputDistribution::Rectangular {
                    mean: check.shunt_ohm,
                    half_width: 0.02 * check.shunt_ohm,
                },
                InputDistribution::Normal {
                    mean: check.measured_strain,
                    standard_uncertainty: check.measured_standard_error_strain,
                },
            ];
            let model = |v: &[f64]| {
                expected_shunt_strain(bridge, v[0], v[1], check.gauge_factor, arm, conversion)
                    .unwrap_or(f64::NAN)
                    / v[2]
            };
            let mc = propagate(&inputs, model, 200_000, 5).unwrap();
            assert_relative(mc.standard_uncertainty, law.standard_uncertainty, 0.02);
            assert_relative(mc.mean, law.factor, 1e-3);
        }
    }

    #[test]
    fn a_step_beyond_the_tolerance_is_refused_with_what_to_check() {
        let off = check(BridgeType::HalfBending, StrainConversion::Linear, 0.5);
        let error = off.gain_correction(5.0).unwrap_err();
        let ShuntError::OutOfTolerance {
            expected_strain,
            measured_strain,
            ..
        } = error
        else {
            panic!("{error:?}")
        };
        assert_relative(measured_strain, 0.5 * expected_strain, 1e-12);
        let message = error.to_string();
        let (expected, measured) = (
            format!("{:.1} um/m", expected_strain * 1e6),
            format!("{:.1} um/m", measured_strain * 1e6),
        );
        for part in [
            expected.as_str(),
            measured.as_str(),
            "-50.00 %",
            "5 %",
            "wiring",
            "gauge factor",
            "bridge type",
        ] {
            assert!(message.contains(part), "{part}: {message}");
        }
        let reversed = check(BridgeType::Quarter, StrainConversion::Linear, -1.0);
        let message = reversed.gain_correction(5.0).unwrap_err().to_string();
        assert!(message.contains("wrong sign"), "{message}");
        let zero = check(BridgeType::Quarter, StrainConversion::Linear, 0.0);
        assert!(matches!(
            zero.gain_correction(5.0),
            Err(ShuntError::OutOfTolerance { .. })
        ));
        let within = check(BridgeType::Quarter, StrainConversion::Linear, 1.049);
        assert!(within.gain_correction(5.0).is_ok());
    }

    #[test]
    fn bad_inputs_are_typed_errors() {
        use BridgeError as E;
        assert!(matches!(
            shunt_relative_change(0.0, 1e5),
            Err(E::NonPositiveResistance { .. })
        ));
        assert!(matches!(
            shunt_relative_change(350.0, -1.0),
            Err(E::NonPositiveResistance { .. })
        ));
        assert!(matches!(
            shunt_relative_change(f64::NAN, 1e5),
            Err(E::NotFinite { .. })
        ));
        assert!(matches!(
            bridge_output_ratio([0.0, -1.0, 0.0, 0.0]),
            Err(E::ArmResistance { arm: 2, .. })
        ));
        assert!(matches!(
            bridge_output_ratio([f64::NAN, 0.0, 0.0, 0.0]),
            Err(E::NotFinite { .. })
        ));
        let quarter = |gf| {
            expected_shunt_strain(
                BridgeType::Quarter,
                350.0,
                1e5,
                gf,
                BridgeArm::R1,
                StrainConversion::Linear,
            )
        };
        for gf in [0.0, -2.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(quarter(gf), Err(E::GaugeFactor(_))), "{gf}");
        }
        for nu in [0.0, -0.1, 0.51, f64::NAN] {
            let bridge = BridgeType::FullPoisson { poisson_ratio: nu };
            assert!(
                matches!(bridge.bridge_factor(), Err(E::PoissonRatio(_))),
                "{nu}"
            );
        }
        assert!(BridgeType::HalfPoisson { poisson_ratio: 0.5 }
            .check()
            .is_ok());
        // A shunt so much smaller than the arm that x rounds to -1.
        assert!(matches!(
            shunt_relative_change(1e300, 1e-300),
            Err(E::ShuntShortsArm { .. })
        ));
        assert!(matches!(
            StrainConversion::InverseOfBridgeLaw.strain(BridgeType::Quarter, 0.5, 2.0),
            Err(E::OutputBeyondBridge { .. })
        ));
        // A gauge factor so near 0 that the strain overflows.
        assert!(matches!(quarter(1e-320), Err(E::NoFiniteResult { .. })));
        let mut bad = check(BridgeType::Quarter, StrainConversion::Linear, 1.0);
        bad.measured_standard_error_strain = -1e-6;
        assert!(matches!(
            bad.gain_correction(5.0),
            Err(ShuntError::Input(E::StandardError(_)))
        ));
        let good = check(BridgeType::Quarter, StrainConversion::Linear, 1.0);
        assert!(matches!(
            good.gain_correction(0.0),
            Err(ShuntError::Tolerance(_))
        ));
        assert!(matches!(
            good.gain_correction(f64::NAN),
            Err(ShuntError::Tolerance(_))
        ));
        let bad = ShuntCheck {
            shunt_tolerance_pct: 100.0,
            ..good
        };
        assert!(matches!(
            bad.gain_correction(5.0),
            Err(ShuntError::Input(E::Tolerance { .. }))
        ));
        let bad = ShuntCheck {
            measured_dof: Some(0.0),
            ..good
        };
        assert!(matches!(
            bad.gain_correction(5.0),
            Err(ShuntError::Input(E::DegreesOfFreedom(_)))
        ));
    }

    /// Finite numbers of any size, with plausible ones mixed in so that
    /// the paths past the checks are reached too.
    fn any_finite() -> impl Strategy<Value = f64> {
        prop_oneof![
            proptest::num::f64::POSITIVE
                | proptest::num::f64::NEGATIVE
                | proptest::num::f64::NORMAL
                | proptest::num::f64::SUBNORMAL
                | proptest::num::f64::ZERO,
            -2.0..2.0f64,
            1.0..1e6f64,
        ]
    }

    fn any_bridge() -> impl Strategy<Value = BridgeType> {
        (0usize..5, any_finite()).prop_map(|(i, nu)| match i {
            0 => BridgeType::Quarter,
            1 => BridgeType::HalfBending,
            2 => BridgeType::HalfPoisson { poisson_ratio: nu },
            3 => BridgeType::FullBending,
            _ => BridgeType::FullPoisson { poisson_ratio: nu },
        })
    }

    proptest! {
        #[test]
        fn no_finite_input_panics(
            bridge in any_bridge(),
            arm in 0usize..4,
            inverse in any::<bool>(),
            numbers in proptest::collection::vec(any_finite(), 11),
            with_dof in any::<bool>(),
        ) {
            let conversion = if inverse {
                StrainConversion::InverseOfBridgeLaw
            } else {
                StrainConversion::Linear
            };
            let arm = BridgeArm::ALL[arm];
            let finite_or_err = |result: Result<f64, BridgeError>| {
                result.map_or(true, f64::is_finite)
            };
            prop_assert!(finite_or_err(shunt_relative_change(numbers[0], numbers[1])));
            prop_assert!(finite_or_err(bridge_output_ratio([
                numbers[0], numbers[1], numbers[2], numbers[3]
            ])));
            prop_assert!(finite_or_err(expected_shunt_strain(
                bridge, numbers[0], numbers[1], numbers[2], arm, conversion
            )));
            prop_assert!(finite_or_err(conversion.strain(bridge, numbers[3], numbers[2])));
            if let Ok(changes) = bridge.relative_changes(numbers[3], numbers[2]) {
                prop_assert!(changes.iter().all(|x| x.is_finite()));
            }
            let check = ShuntCheck {
                bridge,
                conversion,
                arm,
                gauge_ohm: numbers[0],
                shunt_ohm: numbers[1],
                gauge_factor: numbers[2],
                measured_strain: numbers[3],
                gauge_tolerance_pct: numbers[4],
                shunt_tolerance_pct: numbers[5],
                measured_standard_error_strain: numbers[6],
                measured_dof: with_dof.then_some(numbers[7]),
            };
            let _ = check.expected_budget();
            let _ = check.factor_budget();
            if let Ok(correction) = check.gain_correction(numbers[8]) {
                prop_assert!(correction.factor.is_finite());
                prop_assert!(correction.standard_uncertainty.is_finite());
            }
            let _ = check.gain_correction(numbers[8]).map_err(|e| e.to_string());
        }
    }
}
