"""QPSO with the simulator in the loop (seed 001 eq. 9) written as a careful numpy user would:
the whole swarm simulated at once (RK4 on an M x 4 state), on exactly the cases
`hydrofit bench --objective output --export` wrote.

    python3 bench/qpso_output_error.py PROBLEM.bin POPULATION ITERATIONS
"""
import sys
import time

import numpy as np

path, M, iters = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
raw = np.fromfile(path, dtype="<f8")
o = 0


def take(n):
    global o
    v = raw[o:o + n]
    o += n
    return v


cases = []
for _ in range(int(take(1)[0])):
    n = int(take(1)[0])
    t = take(n)
    tau = take(4 * n).reshape(n, 4)
    nu = take(4 * n).reshape(n, 4)
    w = take(4)
    cases.append((t, tau, nu, w))
mrb = take(4)
lo = take(12)
hi = take(12)
evals = 0


def accel(nu, tau, mt, lin, quad):
    """nu_dot for M candidates at once; nu, mt, lin, quad are M x 4 (u, v, w, r)."""
    u, v, r = nu[:, 0], nu[:, 1], nu[:, 3]
    c = np.stack([-mt[:, 1] * v * r, mt[:, 0] * u * r, np.zeros_like(u), (mt[:, 1] - mt[:, 0]) * u * v], axis=1)
    drag = (lin + quad * np.abs(nu)) * nu
    return (tau - c + drag) / mt


def cost(X):
    global evals
    evals += X.shape[0]
    mt = mrb - X[:, 0:4]
    lin, quad = X[:, 4:8], X[:, 8:12]
    total = np.zeros(X.shape[0])
    count = 0
    for t, tau, nu_meas, w in cases:
        nu = np.repeat(nu_meas[:1], X.shape[0], axis=0)
        err = np.zeros(X.shape[0])
        for k in range(len(t)):
            e = nu - nu_meas[k]
            err += (e * e * w).sum(axis=1)
            if k + 1 == len(t):
                break
            span = t[k + 1] - t[k]
            steps = max(1, int(np.ceil(span / 0.01 - 1e-9)))
            h = span / steps
            for _ in range(steps):
                k1 = accel(nu, tau[k], mt, lin, quad)
                k2 = accel(nu + 0.5 * h * k1, tau[k], mt, lin, quad)
                k3 = accel(nu + 0.5 * h * k2, tau[k], mt, lin, quad)
                k4 = accel(nu + h * k3, tau[k], mt, lin, quad)
                nu = nu + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        total += np.nan_to_num(err, nan=1e12)
        count += len(t) * int((w > 0).sum())
    return total / count


rng = np.random.default_rng(1)
X = lo + (hi - lo) * rng.random((M, 12))
t0 = time.perf_counter()
P = X.copy()
pc = cost(X)
g = np.argmin(pc)
for it in range(iters):
    beta = 1.0 - 0.5 * it / iters
    mbest = P.mean(axis=0)
    phi = rng.random((M, 12))
    pd = phi * P + (1 - phi) * P[g]
    step = beta * np.abs(mbest - X) * np.log(1.0 / (1.0 - rng.random((M, 12))))
    X = np.clip(np.where(rng.random((M, 12)) < 0.5, pd + step, pd - step), lo, hi)
    c = cost(X)
    better = c < pc
    P[better] = X[better]
    pc[better] = c[better]
    g = np.argmin(pc)
t = time.perf_counter() - t0
print(f"numpy qpso output error: {evals} evaluations in {t:.2f} s = {evals / t:.1f} evaluations/s ({1e3 * t / evals:.2f} ms each), best cost {pc[g]:.6e}")
