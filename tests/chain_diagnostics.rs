//! acq's chain diagnostics (`acq_algorithms::chain_diagnostics`) against ArviZ
//! 0.23.4, the definitions a posterior's readers expect: the rank-normalised
//! split R-hat (`az.rhat(method="rank")`) and the bulk ESS
//! (`az.ess(method="bulk")`), the tail ESS (`az.ess(method="tail")`), the
//! Monte-Carlo standard errors (`az.mcse(method="mean" | "sd")`) and the 90 %
//! HDI (`az.hdi(hdi_prob=0.9)`) of chains that mix well, mix slowly, drift,
//! have heavy tails, ties, an odd draw count, or sit in different places.
//! ArviZ lives in a scratch virtualenv, never in acq's dependencies.

mod common;

use acq_algorithms::chain_diagnostics::{ess_bulk, ess_tail, hdi, mcse_mean, mcse_sd, rank_rhat};
use rand::{RngExt, SeedableRng};

/// `chains` AR(1) chains `x_t = phi x_{t-1} + e_t` of `draws` draws, with
/// `shift * chain` added, `e` uniform noise passed through `shape`.
fn ar1(
    chains: usize,
    draws: usize,
    phi: f64,
    shift: f64,
    seed: u64,
    shape: fn(f64) -> f64,
) -> Vec<Vec<f64>> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    (0..chains)
        .map(|c| {
            let mut x = 0.0;
            (0..draws)
                .map(|_| {
                    x = phi * x + shape(rng.random::<f64>());
                    x + shift * c as f64
                })
                .collect()
        })
        .collect()
}

#[test]
fn rank_rhat_and_bulk_ess_equal_arviz() {
    let centred = |u: f64| u - 0.5;
    // A Cauchy draw: no mean, no variance; the ranks do not care.
    let cauchy = |u: f64| (std::f64::consts::PI * (u.clamp(1e-12, 1.0 - 1e-12) - 0.5)).tan();
    let rounded = |u: f64| (4.0 * u).floor();
    let cases: Vec<(&str, Vec<Vec<f64>>)> = vec![
        ("independent", ar1(4, 1000, 0.0, 0.0, 1, centred)),
        ("slow mixing", ar1(4, 1000, 0.95, 0.0, 2, centred)),
        ("anti-correlated", ar1(3, 400, -0.6, 0.0, 3, centred)),
        ("apart", ar1(4, 300, 0.5, 0.4, 4, centred)),
        ("heavy tails", ar1(4, 500, 0.3, 0.0, 5, cauchy)),
        ("ties", ar1(2, 200, 0.0, 0.0, 6, rounded)),
        ("odd draws", ar1(3, 101, 0.7, 0.0, 7, centred)),
        ("short", ar1(2, 4, 0.0, 0.0, 8, centred)),
    ];
    let python = common::scratch_python("mcmc");
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("chains.json");
    let as_json: Vec<serde_json::Value> = cases
        .iter()
        .map(|(_, chains)| serde_json::json!(chains))
        .collect();
    std::fs::write(&data, serde_json::Value::Array(as_json).to_string()).unwrap();
    let script = "import json, sys, numpy as np, arviz as az\n\
                  out = []\n\
                  for chains in json.load(open(sys.argv[1])):\n\
                  \x20   a = np.array(chains, dtype=float)\n\
                  \x20   h = az.hdi(a.ravel(), hdi_prob=0.9)\n\
                  \x20   out.append([float(az.rhat(a, method='rank')), float(az.ess(a, method='bulk')), float(az.ess(a, method='tail')), float(az.mcse(a, method='mean')), float(az.mcse(a, method='sd')), float(h[0]), float(h[1])])\n\
                  print(json.dumps(out))\n";
    let output = std::process::Command::new(&python)
        .args(["-c", script, common::path_arg(&data)])
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", common::stderr(&output));
    let theirs: Vec<[f64; 7]> = serde_json::from_slice(&output.stdout).unwrap();
    for ((name, chains), [rhat, ess, tail, se_mean, se_sd, hdi_low, hdi_high]) in
        cases.iter().zip(theirs)
    {
        let mut sorted: Vec<f64> = chains.iter().flatten().copied().collect();
        sorted.sort_by(f64::total_cmp);
        let (low, high) = hdi(&sorted, 0.9).unwrap();
        for (what, ours, arviz) in [
            ("tail ESS", ess_tail(chains).unwrap(), tail),
            ("MCSE of the mean", mcse_mean(chains).unwrap(), se_mean),
            ("MCSE of the sd", mcse_sd(chains).unwrap(), se_sd),
        ] {
            assert!(
                (ours - arviz).abs() <= 1e-8 * arviz.abs(),
                "{name}: {what} {ours}, ArviZ {arviz}"
            );
        }
        assert_eq!((low, high), (hdi_low, hdi_high), "{name}: 90 % HDI");
        let ours_rhat = rank_rhat(chains).unwrap();
        let ours_ess = ess_bulk(chains).unwrap();
        assert!(
            (ours_rhat - rhat).abs() <= 1e-9 * rhat.abs(),
            "{name}: R-hat {ours_rhat}, ArviZ {rhat}"
        );
        assert!(
            (ours_ess - ess).abs() <= 1e-8 * ess.abs(),
            "{name}: bulk ESS {ours_ess}, ArviZ {ess}"
        );
    }
}
