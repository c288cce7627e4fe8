# The peer of `cargo bench -p acq-algorithms --bench gp` in scikit-learn: the same response
# function (Friedman #1 extended, 1 % noise), the same kernel family (constant x Matern 5/2
# ARD + white noise, normalize_y), the same bounds and 5 optimiser starts, timed the same way.
# Not part of any build or test; run in a scratch virtualenv:
#   python3 -m venv /tmp/skvenv && /tmp/skvenv/bin/pip install scikit-learn numpy
#   /tmp/skvenv/bin/python algorithms/benches/sklearn_gp_speed.py
import numpy as np, time
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import Matern, ConstantKernel, WhiteKernel
def response(x, rng):
    y = 10*np.sin(np.pi*x[:,0]*x[:,1]) + 20*(x[:,2]-0.5)**2
    for k in range(3, x.shape[1]):
        y += (10.0/k)*x[:,k]
    return y + 0.1*(rng.random(len(y))-0.5)
for n, d, runs in [(40,4,11),(500,8,3)]:
    rng = np.random.default_rng(7)
    X = rng.random((n,d)); y = response(X, rng)
    ts=[]; lml=None
    for r in range(runs):
        k = ConstantKernel(1.0,(1e-4,1e4))*Matern(length_scale=np.full(d,0.5),length_scale_bounds=(1e-3,1e3),nu=2.5)+WhiteKernel(1e-3,(1e-10,1.0))
        gp = GaussianProcessRegressor(k, normalize_y=True, n_restarts_optimizer=4, random_state=r)
        t=time.perf_counter(); gp.fit(X,y); ts.append(time.perf_counter()-t); lml=gp.log_marginal_likelihood_value_
    print(f"sklearn fit n={n} d={d} ARD matern52 5 starts: median {1e3*sorted(ts)[len(ts)//2]:.1f} ms, lml {lml:.4f}")
