"""Golden values for algorithms/tests/it/gp.rs, computed with scikit-learn.

Reproduce (prints the Rust constants pasted into the test):

    python3 -m venv /tmp/skvenv && /tmp/skvenv/bin/pip install scikit-learn numpy
    /tmp/skvenv/bin/python algorithms/tests/golden/gp_sklearn.py

Produced with scikit-learn 1.9.1, numpy 2.4.6, scipy 1.17.1.

Part 1, fixed hyperparameters: GaussianProcessRegressor(kernel=ConstantKernel(s) * K(l),
alpha=noise, optimizer=None, normalize_y=False). With the noise in `alpha` rather than in a
WhiteKernel, sklearn's predicted std is that of the latent function, which is what acq's
Gp::predict returns. The log marginal likelihood is of the raw outputs with zero mean.

Part 2, fitted hyperparameters on Branin (n = 40, a rank-1 lattice Latin hypercube): the same
model acq fits, inputs scaled to the unit box by the data min/max, outputs standardised
(normalize_y=True uses the population std, as acq does), ConstantKernel(1, (1e-4, 1e4)) *
K(ARD, (1e-3, 1e3)) + WhiteKernel(1e-3, (1e-6, 1)), alpha=0, 50 optimizer restarts. The
reported log marginal likelihood is that of the standardised outputs, the quantity acq's
Gp::log_marginal_likelihood reports. The noise lower bound is 1e-6 rather than acq's default
1e-10 because Branin is noise-free and the optimum sits on that bound: at 1e-10 the kernel
matrix has a condition number near 1e15 and the likelihood itself is only known to about
1e-2, which would make a comparison of two optimisers meaningless.
"""

import warnings

import numpy as np
import sklearn
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, Matern, WhiteKernel

# sklearn warns that the Branin optimum sits on the signal-variance and noise bounds (it does,
# for acq too: Branin is smooth and noise-free) and that some restarts stop
# on "ABNORMAL" line searches; neither changes the best value printed.
warnings.filterwarnings("ignore")

# ---- Part 1: fixed hyperparameters -------------------------------------------------------
TRAIN_X = np.array(
    [
        [0.10, 0.70], [0.35, 0.20], [0.80, 0.90], [0.55, 0.45], [0.95, 0.15], [0.20, 0.30],
        [0.65, 0.75], [0.40, 0.95], [0.05, 0.05], [0.75, 0.35], [0.30, 0.60], [0.90, 0.55],
    ]
)
QUERY_X = np.array([[0.50, 0.50], [0.35, 0.20], [0.00, 1.00], [1.30, -0.20], [0.62, 0.33]])


def smooth(x):
    return np.sin(3.0 * x[:, 0]) + np.cos(2.0 * x[:, 1]) + x[:, 0] * x[:, 1]


TRAIN_Y = smooth(TRAIN_X)
SIGNAL, NOISE = 1.7, 1e-3
CASES = [
    ("SE_ARD", RBF(length_scale=[0.4, 0.7])),
    ("SE_ISO", RBF(length_scale=0.5)),
    ("M12_ARD", Matern(length_scale=[0.4, 0.7], nu=0.5)),
    ("M32_ARD", Matern(length_scale=[0.4, 0.7], nu=1.5)),
    ("M52_ARD", Matern(length_scale=[0.4, 0.7], nu=2.5)),
]


def rust_array(name, values):
    body = ", ".join(repr(float(v)) for v in values)
    return f"const {name}: [f64; {len(values)}] = [{body}];"


print(f"// scikit-learn {sklearn.__version__}, numpy {np.__version__}")
for name, base in CASES:
    gp = GaussianProcessRegressor(
        kernel=ConstantKernel(SIGNAL, "fixed") * base, alpha=NOISE, optimizer=None, normalize_y=False
    )
    gp.fit(TRAIN_X, TRAIN_Y)
    mean, std = gp.predict(QUERY_X, return_std=True)
    print(rust_array(f"{name}_MEAN", mean))
    print(rust_array(f"{name}_STD", std))
    print(f"const {name}_LML: f64 = {float(gp.log_marginal_likelihood_value_)!r};")

# ---- Part 2: fitted hyperparameters on Branin --------------------------------------------
N = 40


def lattice_design(n):
    """Rank-1 lattice Latin hypercube: column 0 is (i + 0.5)/n, column 1 ((7 i + 3) mod n + 0.5)/n."""
    i = np.arange(n)
    return np.column_stack([(i + 0.5) / n, ((7 * i + 3) % n + 0.5) / n])


def branin(x1, x2):
    a, b, c, r, s, t = 1.0, 5.1 / (4.0 * np.pi**2), 5.0 / np.pi, 6.0, 10.0, 1.0 / (8.0 * np.pi)
    return a * (x2 - b * x1**2 + c * x1 - r) ** 2 + s * (1.0 - t) * np.cos(x1) + s


unit = lattice_design(N)
x1 = -5.0 + 15.0 * unit[:, 0]
x2 = 15.0 * unit[:, 1]
y = branin(x1, x2)
raw = np.column_stack([x1, x2])
scaled = (raw - raw.min(axis=0)) / (raw.max(axis=0) - raw.min(axis=0))

for name, base in [
    ("SE", RBF(length_scale=[0.5, 0.5], length_scale_bounds=(1e-3, 1e3))),
    ("M52", Matern(length_scale=[0.5, 0.5], length_scale_bounds=(1e-3, 1e3), nu=2.5)),
]:
    kernel = ConstantKernel(1.0, (1e-4, 1e4)) * base + WhiteKernel(1e-3, (1e-6, 1.0))
    gp = GaussianProcessRegressor(
        kernel=kernel, alpha=0.0, normalize_y=True, n_restarts_optimizer=50, random_state=0
    )
    gp.fit(scaled, y)
    print(f"// {name} fitted kernel: {gp.kernel_}")
    print(f"const BRANIN_{name}_SKLEARN_LML: f64 = {float(gp.log_marginal_likelihood_value_)!r};")
