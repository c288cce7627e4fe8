//! The midpoint rule in a scale's logarithm: how the posterior integrates
//! out its one-dimensional scales (noise, curve error, discrepancy size
//! and length), and draws them afterwards.

use rand::RngExt;

/// The midpoint rule of a scale's integral in its logarithm: the nodes,
/// the log of each node's prior mass, and the cell's width.
#[derive(Clone, Debug)]
pub struct ScaleGrid {
    pub nodes: Vec<f64>,
    log_weights: Vec<f64>,
    cell: f64,
}

impl ScaleGrid {
    /// `count` cells over `range`, each weighted by the prior density of
    /// the scale times the scale (the density of its logarithm), summing
    /// to one.
    pub fn new(range: [f64; 2], count: usize, density: impl Fn(f64) -> f64) -> Self {
        let cell = (range[1] / range[0]).ln() / count as f64;
        let nodes: Vec<f64> = (0..count)
            .map(|k| (range[0].ln() + (k as f64 + 0.5) * cell).exp())
            .collect();
        let mass: Vec<f64> = nodes.iter().map(|&x| density(x) * x).collect();
        let total: f64 = mass.iter().sum();
        ScaleGrid {
            log_weights: mass.iter().map(|m| (m / total).ln()).collect(),
            nodes,
            cell,
        }
    }

    /// The log of the integral of `exp(log_f)` over the prior.
    pub fn log_integral(&self, log_f: impl Fn(f64) -> f64) -> f64 {
        log_sum_exp(&self.log_terms(log_f))
    }

    /// The same, `log_f` given each node's index (to reuse what was
    /// computed at the node).
    pub fn log_integral_by_node(&self, log_f: impl Fn(usize) -> f64) -> f64 {
        let terms: Vec<f64> = (0..self.nodes.len())
            .map(|k| log_f(k) + self.log_weights[k])
            .collect();
        log_sum_exp(&terms)
    }

    /// `log_f` plus the log prior mass at each node.
    fn log_terms(&self, log_f: impl Fn(f64) -> f64) -> Vec<f64> {
        self.nodes
            .iter()
            .zip(&self.log_weights)
            .map(|(&x, w)| log_f(x) + w)
            .collect()
    }

    /// A scale drawn from the posterior `exp(log_f)` times the prior: a
    /// node by its mass, then a place uniform in the logarithm in its cell.
    pub fn draw(&self, log_f: impl Fn(f64) -> f64, rng: &mut impl rand::Rng) -> f64 {
        let terms = self.log_terms(log_f);
        let top = terms.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let weights: Vec<f64> = terms.iter().map(|t| (t - top).exp()).collect();
        let mut pick = rng.random::<f64>() * weights.iter().sum::<f64>();
        let mut index = self.nodes.len() - 1;
        for (k, w) in weights.iter().enumerate() {
            if pick < *w {
                index = k;
                break;
            }
            pick -= w;
        }
        (self.nodes[index].ln() + (rng.random::<f64>() - 0.5) * self.cell).exp()
    }
}

/// `ln(sum(exp(terms)))`, without overflow.
pub fn log_sum_exp(terms: &[f64]) -> f64 {
    let top = terms.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if top == f64::NEG_INFINITY {
        return top;
    }
    top + terms.iter().map(|t| (t - top).exp()).sum::<f64>().ln()
}
