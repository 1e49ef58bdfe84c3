"""QPSO written as a careful numpy user would (the whole swarm vectorised), and pyswarms' PSO,
on exactly the problem `hydrofit bench --export` wrote, with the same population and
iterations, so the evaluation rates can be compared on one machine.

    python3 bench/qpso_compare.py PROBLEM.bin l2|l1 POPULATION ITERATIONS
"""
import sys
import time

import numpy as np

path, norm, M, iters = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
raw = np.fromfile(path, dtype="<f8")
K, p = int(raw[0]), int(raw[1])
o = 2
Phi = raw[o:o + K * p].reshape(K, p); o += K * p
y = raw[o:o + K]; o += K
w = raw[o:o + K]; o += K
lo = raw[o:o + p]; o += p
hi = raw[o:o + p]
Phiw = Phi * w[:, None]
yw = y * w
evals = 0


def cost(X):
    """Costs of a population X (M x p): one matrix product for the whole swarm."""
    global evals
    evals += X.shape[0]
    R = yw[:, None] - Phiw @ X.T
    if norm == "l2":
        return (R * R).sum(axis=0) / K
    return np.abs(R).sum(axis=0) / np.sqrt(K)


def qpso(seed=1):
    rng = np.random.default_rng(seed)
    X = lo + (hi - lo) * rng.random((M, p))
    P = X.copy()
    pc = cost(X)
    g = np.argmin(pc)
    for it in range(iters):
        beta = 1.0 - 0.5 * it / iters
        mbest = P.mean(axis=0)
        phi = rng.random((M, p))
        pd = phi * P + (1 - phi) * P[g]
        u = 1.0 - rng.random((M, p))
        step = beta * np.abs(mbest - X) * np.log(1.0 / u)
        X = np.where(rng.random((M, p)) < 0.5, pd + step, pd - step)
        X = np.clip(X, lo, hi)
        c = cost(X)
        better = c < pc
        P[better] = X[better]
        pc[better] = c[better]
        g = np.argmin(pc)
    return P[g], pc[g]


t0 = time.perf_counter()
best, bc = qpso()
t = time.perf_counter() - t0
print(f"numpy qpso {norm}: {evals} evaluations in {t:.3f} s = {evals / t:.0f} evaluations/s, best cost {bc:.6e}")

try:
    import pyswarms as ps
except ImportError:
    print("pyswarms not installed: pip install pyswarms")
    sys.exit(0)
evals = 0
opt = ps.single.GlobalBestPSO(n_particles=M, dimensions=p, options={"c1": 1.49618, "c2": 1.49618, "w": 0.7298}, bounds=(lo, hi))
t0 = time.perf_counter()
bc, best = opt.optimize(cost, iters=iters, verbose=False)
t = time.perf_counter() - t0
print(f"pyswarms pso {norm}: {evals} evaluations in {t:.3f} s = {evals / t:.0f} evaluations/s, best cost {bc:.6e}")
