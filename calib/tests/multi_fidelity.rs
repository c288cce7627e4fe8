//! Co-kriging and the two-level search on the published pair of Forrester,
//! Sobester and Keane (2007, Proc. R. Soc. A 463, 3251): the expensive
//! `f_e(x) = (6x - 2)^2 sin(12x - 4)` and the cheap
//! `f_c(x) = 0.5 f_e(x) + 10 (x - 0.5) + 5`, so that exactly
//! `f_e = 2 f_c - 20 (x - 0.5) - 10`: rho is 2 and the discrepancy a line.
//! The minimum of `f_e` is -6.020740 at x = 0.757249 (golden-section
//! search on the closed form).

use acq_calib::bo::{minimise as minimise_single, BoSettings, Stop};
use acq_calib::gp::{Gp, GpSettings};
use acq_calib::multi_fidelity::{minimise, CoKriging, Fidelity, MultiFidelitySettings};

fn expensive(x: f64) -> f64 {
    (6.0 * x - 2.0).powi(2) * (12.0 * x - 4.0).sin()
}

fn cheap(x: f64) -> f64 {
    0.5 * expensive(x) + 10.0 * (x - 0.5) + 5.0
}

const MINIMUM_X: f64 = 0.757_248_759;
const MINIMUM: f64 = -6.020_740_056;

fn pairs(xs: &[f64], f: fn(f64) -> f64) -> Vec<(Vec<f64>, f64)> {
    xs.iter().map(|&x| (vec![x], f(x))).collect()
}

/// The RMSE of a predictor against `f_e` on 201 points of [0, 1].
fn rmse(predict: impl Fn(f64) -> f64) -> f64 {
    let n = 201;
    let sum: f64 = (0..n)
        .map(|i| {
            let x = i as f64 / (n - 1) as f64;
            (predict(x) - expensive(x)).powi(2)
        })
        .sum();
    (sum / n as f64).sqrt()
}

fn gp_settings() -> GpSettings {
    GpSettings {
        input_bounds: Some(vec![(0.0, 1.0)]),
        noise_bounds: (1e-10, 1e-6),
        ..GpSettings::default()
    }
}

/// The paper's designs: eleven cheap points, four expensive ones among
/// them. Four expensive points alone miss the dip near 0.75 entirely; the
/// cheap points carry its shape, and co-kriging scales it by rho.
#[test]
fn co_kriging_recovers_the_expensive_function_from_four_expensive_points() {
    let cheap_xs: Vec<f64> = (0..=10).map(|i| i as f64 / 10.0).collect();
    let expensive_xs = [0.0, 0.4, 0.6, 1.0];
    let model = CoKriging::fit(
        &pairs(&cheap_xs, cheap),
        &pairs(&expensive_xs, expensive),
        &gp_settings(),
    )
    .unwrap();
    let single = {
        let (inputs, outputs): (Vec<Vec<f64>>, Vec<f64>) =
            pairs(&expensive_xs, expensive).into_iter().unzip();
        Gp::fit(&inputs, &outputs, &gp_settings()).unwrap()
    };
    let co_kriging_rmse = rmse(|x| model.predict(&[x]).mean);
    let single_rmse = rmse(|x| single.predict(&[x]).mean);
    println!(
        "rho {:.4}, RMSE co-kriging {co_kriging_rmse:.4}, single-fidelity GP {single_rmse:.4}",
        model.rho()
    );
    // rho is exactly 2 in the closed form; the discrepancy GP sees four
    // points, so its constant mean and rho trade a little.
    assert!((model.rho() - 2.0).abs() < 0.1, "rho {}", model.rho());
    // f_e spans 22 units on [0, 1]: an RMSE under 0.5 is the curve drawn
    // right (the cheap GP on eleven points is the limit), while the GP of
    // four expensive points is off by several units.
    assert!(co_kriging_rmse < 0.5, "co-kriging RMSE {co_kriging_rmse}");
    assert!(single_rmse > 5.0 * co_kriging_rmse, "single {single_rmse}");
    // At an expensive point the prediction is the run, and sure of it.
    let at_run = model.predict(&[0.6]);
    assert!((at_run.mean - expensive(0.6)).abs() < 1e-3, "{at_run:?}");
    assert!(at_run.std < 1e-2 * 22.0, "{at_run:?}");
    // Away from the expensive runs, cheap and expensive move together.
    assert!(model.predict(&[0.75]).correlation > 0.5);
}

/// With expensive runs ten times the cost of cheap ones, the two-level
/// search finds the minimum with fewer expensive runs than Bayesian
/// optimisation of the expensive function alone from the same start.
#[test]
fn the_two_level_search_finds_the_minimum_with_fewer_expensive_runs() {
    const CHEAP_S: f64 = 0.1;
    const EXPENSIVE_S: f64 = 1.0;
    // Within 0.05 of the minimum's value: the dip is 0.05 deep 0.006
    // either side of x*, so this is x* to about 0.006.
    let tolerance = 0.05;
    let settings = MultiFidelitySettings {
        max_evaluations: 60,
        max_expensive: 20,
        target_loss: Some(MINIMUM + tolerance),
        gp: GpSettings {
            noise_bounds: (1e-10, 1e-6),
            ..MultiFidelitySettings::default().gp
        },
        seed: 3,
        ..MultiFidelitySettings::default()
    };
    let cheap_start: Vec<Vec<f64>> = (0..=4).map(|i| vec![i as f64 / 4.0]).collect();
    let expensive_start = vec![vec![0.0], vec![0.5], vec![1.0]];
    let result = minimise::<acq_calib::bo::BoError>(
        cheap_start,
        expensive_start.clone(),
        |level, points| {
            Ok(points
                .iter()
                .map(|x| match level {
                    Fidelity::Cheap => (Some(cheap(x[0]).into()), CHEAP_S),
                    Fidelity::Expensive => (Some(expensive(x[0]).into()), EXPENSIVE_S),
                })
                .collect())
        },
        &settings,
    )
    .unwrap();
    let best = &result.runs[result.best];
    let expensive_runs = result.count(Fidelity::Expensive);
    let cheap_runs = result.count(Fidelity::Cheap);
    println!(
        "two levels: {expensive_runs} expensive + {cheap_runs} cheap runs, best {:?} at {:?}, rho {:?}",
        best.loss, best.unit_point, result.rho
    );
    assert_eq!(result.stop, Stop::TargetReached);
    assert_eq!(best.level, Fidelity::Expensive);
    assert!((best.unit_point[0] - MINIMUM_X).abs() < 0.01);
    assert!(
        (result.cost_s[0] - CHEAP_S).abs() < 1e-12
            && (result.cost_s[1] - EXPENSIVE_S).abs() < 1e-12
    );
    // The single-level search from the same expensive start.
    let single = minimise_single::<acq_calib::bo::BoError, f64>(
        expensive_start,
        |points| Ok(points.iter().map(|x| Some(expensive(x[0]))).collect()),
        &BoSettings {
            max_evaluations: 40,
            target_loss: Some(MINIMUM + tolerance),
            gp: settings.gp.clone(),
            seed: 3,
            ..BoSettings::default()
        },
    )
    .unwrap();
    let single_runs = single.observations.len();
    println!(
        "one level: {single_runs} expensive runs, stop {:?}",
        single.stop
    );
    let cost =
        |expensive: usize, cheap: usize| expensive as f64 * EXPENSIVE_S + cheap as f64 * CHEAP_S;
    assert!(
        expensive_runs < single_runs,
        "{expensive_runs} expensive runs with two levels, {single_runs} with one"
    );
    assert!(cost(expensive_runs, cheap_runs) < cost(single_runs, 0));
}

/// Local steps with the cheap level's slopes, on residuals with a closed
/// form: the expensive `r(x) = (x0 - 0.3, x1 - 0.6, (x0 + x1)/2 - 0.45)`
/// is zero at (0.3, 0.6); the cheap level's residuals are those shifted
/// by (0.2, -0.1, 0.05), so its own optimum lies elsewhere (about (0.1,
/// 0.7)) while its slopes are the expensive ones. Shifted by the levels'
/// difference at the centre, the cheap runs give the exact model, and the
/// local steps reach the expensive optimum in a few expensive runs.
#[test]
fn local_steps_with_the_cheap_levels_slopes_find_the_expensive_optimum() {
    use acq_calib::bo::Outcome;
    use acq_calib::trust_region::TrustRegionSettings;
    let residuals = |x: &[f64], shift: [f64; 3]| -> Vec<f64> {
        vec![
            x[0] - 0.3 + shift[0],
            x[1] - 0.6 + shift[1],
            0.5 * (x[0] + x[1]) - 0.45 + shift[2],
        ]
    };
    let outcome = |r: Vec<f64>| Outcome {
        loss: r.iter().map(|v| v * v).sum::<f64>(),
        residuals: r,
    };
    let settings = MultiFidelitySettings {
        max_evaluations: 60,
        max_expensive: 12,
        // 1e-8 in the sum of squares: within 1e-4 of the optimum.
        target_loss: Some(1e-8),
        local_steps: Some(TrustRegionSettings::default()),
        local_steps_after: 0,
        seed: 1,
        ..MultiFidelitySettings::default()
    };
    let cheap_start = vec![
        vec![0.0, 0.0],
        vec![1.0, 0.0],
        vec![0.0, 1.0],
        vec![1.0, 1.0],
        vec![0.5, 0.5],
    ];
    let expensive_start = cheap_start[..3].to_vec();
    let result = minimise::<acq_calib::bo::BoError>(
        cheap_start,
        expensive_start,
        |level, points| {
            Ok(points
                .iter()
                .map(|x| match level {
                    Fidelity::Cheap => (Some(outcome(residuals(x, [0.2, -0.1, 0.05]))), 0.1),
                    Fidelity::Expensive => (Some(outcome(residuals(x, [0.0; 3]))), 1.0),
                })
                .collect())
        },
        &settings,
    )
    .unwrap();
    let best = &result.runs[result.best];
    println!(
        "{} expensive + {} cheap runs, best {:?} at {:?}",
        result.count(Fidelity::Expensive),
        result.count(Fidelity::Cheap),
        best.loss,
        best.unit_point
    );
    assert_eq!(result.stop, Stop::TargetReached);
    assert!((best.unit_point[0] - 0.3).abs() < 1e-3 && (best.unit_point[1] - 0.6).abs() < 1e-3);
    assert!(result.count(Fidelity::Expensive) <= 8);
}
