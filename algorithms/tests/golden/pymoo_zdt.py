"""Reference run of pymoo's NSGA-II on ZDT1-3, for the side-by-side test in algorithms/tests/it/moo.rs.

Run: python3 -m venv /tmp/pymoo-venv && /tmp/pymoo-venv/bin/pip install pymoo
     /tmp/pymoo-venv/bin/python algorithms/tests/golden/pymoo_zdt.py

Settings match the Rust test: population 100, 250 generations, pymoo's default NSGA-II
operators (SBX prob 0.9 eta 15, PM eta 20 prob 1/n), seeds 1..5. The reported number is
the mean over seeds of the hypervolume (reference point 1.1, 1.1) of the final front
(`res.F`, the non-dominated set of the final population), and the mean wall time per run.
"""

import time

import numpy as np
import pymoo
from pymoo.algorithms.moo.nsga2 import NSGA2
from pymoo.indicators.hv import HV
from pymoo.optimize import minimize
from pymoo.problems import get_problem

SEEDS = [1, 2, 3, 4, 5]
REFERENCE = np.array([1.1, 1.1])



def true_front(name):
    """A dense sample of the analytic Pareto front (dominated points are ignored by HV)."""
    f1 = np.linspace(0.0, 1.0, 100_001)
    if name == "zdt1":
        f2 = 1.0 - np.sqrt(f1)
    elif name == "zdt2":
        f2 = 1.0 - f1**2
    else:
        f2 = 1.0 - np.sqrt(f1) - f1 * np.sin(10.0 * np.pi * f1)
    return np.column_stack([f1, f2])


print(f"pymoo {pymoo.__version__}")
for name in ["zdt1", "zdt2", "zdt3"]:
    problem = get_problem(name)
    indicator = HV(ref_point=REFERENCE)
    volumes, seconds = [], []
    for seed in SEEDS:
        start = time.perf_counter()
        res = minimize(problem, NSGA2(pop_size=100), ("n_gen", 250), seed=seed, verbose=False)
        seconds.append(time.perf_counter() - start)
        volumes.append(indicator(res.F))
    true_front_hv = indicator(true_front(name))
    print(
        f"{name}: mean_hv={np.mean(volumes):.6f} min_hv={np.min(volumes):.6f} "
        f"per_seed={[round(v, 6) for v in volumes]} mean_seconds={np.mean(seconds):.3f} "
        f"true_front_hv={true_front_hv:.6f}"
    )
