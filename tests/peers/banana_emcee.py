"""emcee 3.1.6 on acq's banana posterior: y = a exp(-b t) seen at t = 1, 2
(sd 0.1), a uniform prior on a in [0.2, 3] and b in [0.05, 2].

Three runs of 32 walkers x 8,000 steps (2,000 discarded), each timed
(sampling only) with its effective samples (draws over the integrated
autocorrelation time); the quantiles of the first run's draws; and, given
a JSON file of acq's chains per parameter, ArviZ's rank R-hat and bulk
ESS of them. Prints one JSON object. Used by tests/posterior.rs and
benches/posterior.rs."""
import json, sys, time

import arviz as az
import emcee
import numpy as np

t = np.array([1.0, 2.0])
y = np.array([0.62, 0.35])
sd = 0.1
low = np.array([0.2, 0.05])
high = np.array([3.0, 2.0])


def log_density(p):
    if np.any(p < low) or np.any(p > high):
        return -np.inf
    r = y - p[0] * np.exp(-p[1] * t)
    return -0.5 * np.sum((r / sd) ** 2)


runs, first = [], None
for run in range(3):
    np.random.seed(run)
    start = np.array([0.8, 0.4]) + 0.01 * np.random.standard_normal((32, 2))
    sampler = emcee.EnsembleSampler(32, 2, log_density)
    began = time.perf_counter()
    sampler.run_mcmc(start, 8000)
    seconds = time.perf_counter() - began
    chain = sampler.get_chain(discard=2000)
    tau = np.max(emcee.autocorr.integrated_time(chain, quiet=True))
    ess = chain.shape[0] * chain.shape[1] / tau
    runs.append([ess / seconds, ess, seconds])
    if first is None:
        first = chain.reshape(-1, 2)
levels = [0.05, 0.25, 0.5, 0.75, 0.95]
out = {
    "runs": runs,
    "ess": runs[0][1],
    "quantiles": [[float(np.quantile(first[:, i], p)) for p in levels] for i in range(2)],
}
if len(sys.argv) > 1:
    acq = json.load(open(sys.argv[1]))
    out["rhat"] = [float(az.rhat(np.array(c), method="rank")) for c in acq]
    out["ess_bulk"] = [float(az.ess(np.array(c), method="bulk")) for c in acq]
print(json.dumps(out))
