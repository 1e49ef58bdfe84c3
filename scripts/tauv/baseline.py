#!/usr/bin/env python3
"""A per-DOF baseline for the converted TAUV project (scripts/tauv/convert.py): what an engineer
writes in fifty lines before trusting a tool.

Per DOF (surge, sway, heave, yaw), on the `role: train` runs: m v' = tau - d v - d2 |v| v + c,
with m, d, d2 >= 0 and c free (a constant force: buoyancy, a thruster offset), simulated over
each whole run from its first sample under the logged command (zero-order hold, RK4 on a
20 ms grid), fitted by scipy's least squares on the output error. Velocities are the
navigation log's u, v, w; the yaw rate is the derivative of its unwrapped heading (no rates are
logged), smoothed over 0.3 s. NMAE = mean |v_model - v_meas| / mean |v_meas| per held-out run
and DOF; predicting rest scores 1.

    pip install numpy scipy
    python3 scripts/tauv/baseline.py /tmp/tauv     # writes /tmp/tauv/baseline.json
"""

import json
import sys
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

DOFS = ["surge", "sway", "heave", "yaw"]
DT = 0.02


def load(run):
    th = np.genfromtxt(run / "thrust.csv", delimiter=",", names=True)
    nav = np.genfromtxt(run / "nav.csv", delimiter=",", names=True)
    role = "validate" if "validate" in (run / "run.yaml").read_text().split("\n")[0] else "train"
    t = nav["t"]
    psi = np.unwrap(np.radians(nav["yaw_deg"]))
    grid = np.arange(t[0], t[-1], DT)
    r = np.gradient(np.interp(grid, t, psi), grid)
    k = max(1, int(round(0.3 / DT)))
    r = np.convolve(r, np.ones(k) / k, mode="same")
    meas = {
        "surge": np.interp(grid, t, nav["u_m_s"]),
        "sway": np.interp(grid, t, nav["v_m_s"]),
        "heave": np.interp(grid, t, nav["w_m_s"]),
        "yaw": r,
    }
    idx = np.clip(np.searchsorted(th["t"], grid, side="right") - 1, 0, len(th) - 1)
    tau = {
        "surge": th["X_N"][idx],
        "sway": th["Y_N"][idx],
        "heave": th["Z_N"][idx],
        "yaw": th["N_Nm"][idx],
    }
    return {"name": run.name, "role": role, "meas": meas, "tau": tau}


def simulate(p, tau, v0):
    m, d, d2, c = p
    f = lambda v, x: (x - d * v - d2 * abs(v) * v + c) / m
    v = np.empty(len(tau))
    v[0] = v0
    for k in range(len(tau) - 1):
        x, y = tau[k], v[k]
        k1 = f(y, x)
        k2 = f(y + 0.5 * DT * k1, x)
        k3 = f(y + 0.5 * DT * k2, x)
        k4 = f(y + DT * k3, x)
        v[k + 1] = y + DT / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return v


def fit(runs, dof):
    def res(p):
        out = []
        for r in runs:
            y = r["meas"][dof]
            out.append((simulate(p, r["tau"][dof], y[0]) - y) / max(np.sqrt(np.mean(y**2)), 1e-6))
        return np.concatenate(out)

    mass0 = 1.0 if dof == "yaw" else 30.0
    best = None
    for m0 in (mass0, 3 * mass0):
        s = least_squares(res, [m0, 10.0 * mass0 / 30.0, 0.0, 0.0],
                          bounds=([1e-3, 0, 0, -np.inf], [np.inf] * 4))
        if best is None or s.cost < best.cost:
            best = s
    return best.x


def main():
    root = Path(sys.argv[1])
    runs = [load(r) for r in sorted((root / "cases" / "pool").iterdir()) if r.is_dir()]
    train = [r for r in runs if r["role"] == "train"]
    held = [r for r in runs if r["role"] == "validate"]
    out = {"params": {}, "runs": {}}
    for dof in DOFS:
        p = fit(train, dof)
        out["params"][dof] = dict(zip(["m", "d", "d2", "c"], map(float, p)))
        for r in held:
            y = r["meas"][dof]
            e = np.mean(np.abs(simulate(p, r["tau"][dof], y[0]) - y)) / max(np.mean(np.abs(y)), 1e-9)
            out["runs"].setdefault(r["name"], {})[dof] = float(e)
    means = {d: float(np.mean([out["runs"][r["name"]][d] for r in held])) for d in DOFS}
    out["mean_nmae"] = means
    (root / "baseline.json").write_text(json.dumps(out, indent=1))
    print("params", json.dumps(out["params"]))
    print("held-out NMAE", " ".join(f"{d} {means[d]:.3f}" for d in DOFS))


if __name__ == "__main__":
    main()
