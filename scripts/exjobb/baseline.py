#!/usr/bin/env python3
"""Per-DOF output-error baseline for the ExjobbROV project written by convert.py.

    python3 scripts/exjobb/baseline.py OUT_PROJECT [--fit-inertia]

For each of roll, pitch, yaw, fits on the `role: train` runs
    I w' = tau + D_w w + D_ww |w| w + G s(phi, theta) + c
(w = p, q, r; tau = K, M, N from thrust.csv; s = sin(phi) cos(theta) for roll, sin(theta) for
pitch, none for yaw, from the logged attitude; G = B z_B; c a constant moment), simulated over
each whole run from its first nav.csv sample under the logged tau (zero-order hold, RK4 at
50 Hz), by scipy.optimize.least_squares on the simulated-minus-logged rate. I is the vehicle's
inertia from pipeline.yaml (the thesis's rigid-body + added totals); --fit-inertia fits it too
(written to baseline_fit_inertia.json instead). Scores every run by
NMAE = mean|w_model - w_meas| / mean|w_meas| against the EKF rates of nav.csv (predicting rest
scores 1.0), also for the thesis's own coefficients, and writes OUT_PROJECT/baseline.json.
"""
import json
import re
import sys
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

DT = 0.02
EXCITED_DPS = 10.0  # a held-out run "excites" a DOF when its mean |rate| is at least this
B = 6.621 * 9.82  # W = B (neutral, thesis); only used to express G as z_B
THESIS = {  # tab:parameterConstants: linear, quadratic damping [kg m^2], G = B z_B [N m]
    "roll": (-0.8842, -0.6682, B * -0.0420),
    "pitch": (-0.8547, -0.3354, B * -0.0420),
    "yaw": (-1.0280, -1.0249, 0.0),
}
DOFS = {"roll": ("K_Nm", "p_dps", "xx", "K"), "pitch": ("M_Nm", "q_dps", "yy", "M"),
        "yaw": ("N_Nm", "r_dps", "zz", "N")}


def read_csv(path):
    names = path.read_text().split("\n", 1)[0].strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {n: data[:, i] for i, n in enumerate(names)}


def load_run(folder):
    th, nav = read_csv(folder / "thrust.csv"), read_csv(folder / "nav.csv")
    role = re.search(r"role:\s*(\w+)", (folder / "run.yaml").read_text()).group(1)
    t = np.arange(nav["t"][0], nav["t"][-1], DT)
    k = np.clip(np.searchsorted(th["t"], t, side="right") - 1, 0, None)  # zero-order hold
    phi = np.radians(np.interp(t, nav["t"], nav["roll_deg"]))
    theta = np.radians(np.interp(t, nav["t"], nav["pitch_deg"]))
    run = {"name": folder.name, "role": role}
    for dof, (tcol, wcol, _, _) in DOFS.items():
        s = {"roll": np.sin(phi) * np.cos(theta), "pitch": np.sin(theta), "yaw": 0 * t}[dof]
        run[dof] = (th[tcol][k], s, np.radians(np.interp(t, nav["t"], nav[wcol])))
    return run


def simulate(par, inertia, tau, s, w0):
    a, b, g, c = par
    f = lambda w, u: (u + a * w + b * abs(w) * w) / inertia
    w, out = float(w0), np.empty(len(tau))
    for i, u in enumerate(tau + g * s + c):  # inputs held over the step
        out[i] = w
        k1 = f(w, u); k2 = f(w + 0.5 * DT * k1, u); k3 = f(w + 0.5 * DT * k2, u)
        w += DT / 6 * (k1 + 2 * k2 + 2 * k3 + f(w + DT * k3, u))
        if not abs(w) < 50.0:  # diverged: hold at the bound, the cost will say so
            out[i:] = np.sign(w) * 50.0
            break
    return out


def nmae(model, meas):
    return float(np.mean(np.abs(model - meas)) / np.mean(np.abs(meas)))


def main(project, fit_inertia=False):
    project = Path(project)
    inertia = dict(re.findall(r"(xx|yy|zz):\s*([0-9.]+)", (project / "pipeline.yaml").read_text()))
    runs = [load_run(f) for f in sorted((project / "cases" / "pool").iterdir()) if f.is_dir()]
    train = [r for r in runs if r["role"] == "train"]
    out = {"model": "I w' = tau + D_w w + D_ww |w| w + G s(phi,theta) + c (per DOF, output error)",
           "dofs": {}, "runs": {r["name"]: {"role": r["role"]} for r in runs}, "heldout_mean_nmae": {}}
    for dof, (_, _, ax, F) in DOFS.items():
        I0 = float(inertia[ax])
        has_g = dof != "yaw"
        nI = 1 if fit_inertia else 0

        def full(x):  # -> (coefficients, inertia)
            return (x[nI], x[nI + 1], x[nI + 2] if has_g else 0.0, x[-1]), (x[0] if nI else I0)

        def resid(x):
            p, I = full(x)
            return np.concatenate([simulate(p, I, *r[dof][:2], r[dof][2][0]) - r[dof][2]
                                   for r in train])
        x0 = [I0] * nI + [*THESIS[dof][:2]] + ([THESIS[dof][2]] if has_g else []) + [0.0]
        lo = [0.02] * nI + [-20, -20] + ([-20] if has_g else []) + [-5]
        hi = [10.0] * nI + [0, 0] + ([0] if has_g else []) + [5]
        fit = least_squares(resid, x0, bounds=(lo, hi), x_scale=1.0)
        J = fit.jac
        sigma2 = 2 * fit.cost / max(len(fit.fun) - len(x0), 1)
        se = np.sqrt(np.diag(np.linalg.pinv(J.T @ J)) * sigma2)  # white-residual (optimistic)
        p, I = full(fit.x)
        w = {"roll": "p", "pitch": "q", "yaw": "r"}[dof]
        names = [f"{F}_{w}", f"{F}_{w}{w}", "B*z_B", f"{F}_0"]
        out["dofs"][dof] = {
            "inertia_kg_m2": float(I), "inertia_fitted": fit_inertia, "inertia_thesis": I0,
            "fitted": dict(zip(names, map(float, p))),
            "stderr_white": dict(zip(["I"] * nI + [n for n in names if has_g or n != "B*z_B"],
                                     map(float, se))),
            "z_B_m": float(p[2] / B) if has_g else None,
            "thesis": dict(zip(names, [*THESIS[dof], 0.0])),
            "train_rms_dps": float(np.degrees(np.sqrt(np.mean(fit.fun ** 2)))),
        }
        for r in runs:
            tau, s, meas = r[dof]
            r_out = out["runs"][r["name"]].setdefault("dofs", {})
            r_out[dof] = {"nmae": nmae(simulate(p, I, tau, s, meas[0]), meas),
                          "nmae_thesis": nmae(simulate((*THESIS[dof], 0.0), I0, tau, s, meas[0]), meas),
                          "nmae_rest": 1.0,
                          "mean_abs_rate_dps": float(np.degrees(np.mean(np.abs(meas))))}
    held = [r["name"] for r in runs if r["role"] == "validate"]
    ex = out["heldout_mean_nmae_excited"] = {"threshold_mean_abs_rate_dps": EXCITED_DPS}
    for dof in DOFS:
        cells = [out["runs"][n]["dofs"][dof] for n in held]
        hot = [c for c in cells if c["mean_abs_rate_dps"] >= EXCITED_DPS]
        for key in ("nmae", "nmae_thesis"):
            out["heldout_mean_nmae"].setdefault(key, {})[dof] = float(np.mean([c[key] for c in cells]))
            ex.setdefault(key, {})[dof] = float(np.mean([c[key] for c in hot])) if hot else None
        ex.setdefault("runs", {})[dof] = len(hot)
    out["heldout_mean_nmae"]["nmae_rest"] = {d: 1.0 for d in DOFS}

    print(f"{'run':26s} {'role':8s} " + " ".join(f"{d + ' fit/thesis':>17s}" for d in DOFS)
          + "   (NMAE; rest = 1.00; mean|w| deg/s)")
    for name, r in out["runs"].items():
        cells = " ".join(f"{r['dofs'][d]['nmae']:5.2f}/{r['dofs'][d]['nmae_thesis']:5.2f} ({r['dofs'][d]['mean_abs_rate_dps']:3.0f})"
                         for d in DOFS)
        print(f"{name:26s} {r['role']:8s} {cells}")
    h = out["heldout_mean_nmae"]
    print(f"{'held-out mean':35s} " + " ".join(f"{h['nmae'][d]:5.2f}/{h['nmae_thesis'][d]:5.2f}      " for d in DOFS))
    print(f"{'held-out mean, excited only':35s} " + " ".join(
        f"{ex['nmae'][d]:5.2f}/{ex['nmae_thesis'][d]:5.2f} [{ex['runs'][d]}]  " for d in DOFS)
        + f" [runs with mean|w| >= {EXCITED_DPS:.0f} deg/s]")
    print("\nfitted (thesis) coefficients, SNAME signs, N m s/rad, N m s^2/rad^2, N m:")
    for dof, v in out["dofs"].items():
        print(f"  {dof:5s} I={v['inertia_kg_m2']:.3f} ({v['inertia_thesis']:.3f})  " + "  ".join(
            f"{k}={v['fitted'][k]:+.3f} ({v['thesis'][k]:+.3f})" for k in v["fitted"])
            + (f"  z_B={v['z_B_m']:+.4f} m" if v["z_B_m"] is not None else "")
            + f"  train rms {v['train_rms_dps']:.1f} deg/s")
    dest = project / ("baseline_fit_inertia.json" if fit_inertia else "baseline.json")
    dest.write_text(json.dumps(out, indent=2) + "\n")
    print(f"\nwrote {dest}")


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if a != "--fit-inertia"]
    if len(args) != 1:
        sys.exit(__doc__)
    main(args[0], fit_inertia="--fit-inertia" in sys.argv)
