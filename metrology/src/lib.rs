//! The arithmetic of JCGM 100:2008 (the GUM) that a measurement chain
//! needs, and nothing of CAN, rigs or studies.
//!
//! - [`bridge`]: Wheatstone bridges of strain gauges: the strain a shunt
//!   resistor simulates (the bridge's exact output, read as the channel
//!   converts it), and the gain correction a shunt check gives, with its
//!   budget, refused when the step is too far off to be a gain error.
//! - [`budget`]: contributions (a standard uncertainty, its sensitivity
//!   coefficient and degrees of freedom), the Type B conversions (a stated
//!   expanded uncertainty, a rectangular limit, a resolution), the combined
//!   standard uncertainty, Welch-Satterthwaite's effective degrees of
//!   freedom and the coverage factor for 95 % from Student's t.
//! - [`grid_convergence`]: a solver's discretisation error from runs at
//!   several element sizes (Celik et al. 2008; Eça and Hoekstra 2014 with
//!   more sizes): the observed order, the extrapolated value and the fine
//!   grid's convergence index, whose `u_num` V&V 20 takes.
//! - [`curve`]: a calibration curve fitted by least squares to a
//!   certificate's points, with the curve's own standard uncertainty at
//!   every reading (from the points' stated uncertainties, or from the
//!   residual scatter when they state none, as JCGM 100 example H.3 does).
//! - [`monte_carlo`]: propagation of distributions (JCGM 101, GUM
//!   Supplement 1), the check of the first-order law on a non-linear model.

pub mod bridge;
pub mod budget;
pub mod curve;
pub mod grid_convergence;
pub mod monte_carlo;
