#!/usr/bin/env python3
"""Writes a six-DOF hydrofit project from a simulated BlueROV2 Heavy's MATLAB tables, and
compares what hydrofit identified with the simulator's coefficients.

The tables are `matlab_data/pose_data.csv` and `matlab_data/thrust_data.csv` of
github.com/dream-oyh/6dof-rov-dynamics-forward (no licence: nothing of them is copied into
hydrofit; give the path of a clone or of its `matlab_data/` folder). They have no header and no
time column: each row is a 0.05 s step (the repository's `robot/rov.py` says so), the pose
table's nine columns roll, pitch, yaw (rad) and the body velocities u, v, w, p, q, r, the
thrust table's six the body wrench X, Y, Z, K, M, N. So they are converted, into `OUT` (outside
the repository): 115 s cut into four runs of 29 s, the last held out.

    python3 scripts/bluerov2_sim/six_dof.py SRC OUT
    hydrofit build --project OUT
    python3 scripts/heldout.py OUT --runs
    python3 scripts/bluerov2_sim/six_dof.py --compare OUT
"""

import argparse
import math
from pathlib import Path

from compare import compare

STEP_S = 0.05
RUNS = 4

PIPELINE = """\
# A simulated BlueROV2 Heavy in six DOF (MATLAB tables of github.com/dream-oyh/
# 6dof-rov-dynamics-forward, converted by scripts/bluerov2_sim/six_dof.py; no licence: not
# part of hydrofit). Mass and inertia as the repository's robot/rov.py states them.
vehicle:
  name: simulated BlueROV2 Heavy (dream-oyh/6dof-rov-dynamics-forward)
  mass_kg: 11.5
  inertia_kg_m2: {xx: 0.16, yy: 0.16, zz: 0.16}
  dofs: [surge, sway, heave, roll, pitch, yaw]
  structure: diagonal
stages:
  pool: {kind: pool, inputs: ["cases/pool/*/"]}
  fit: {kind: fit, from: [pool]}
  fit_ols: {kind: fit, from: [pool], settings: {method: ols}}
  validate: {kind: validate, from: [fit, fit_ols, pool]}
  diagnose: {kind: diagnose, from: [fit, pool]}
  report: {kind: report, from: [fit, fit_ols, pool, validate, diagnose]}
"""

# The simulator's coefficients (`robot/rov.py`: the BlueROV2 Heavy values of Wu 2018), its
# net weight W - B = 112.8 - 114.8 N and moment eta_z = z_g W = 0.02 m * 112.8 N.
SIMULATOR = {
    "X_udot": -5.5, "Y_vdot": -12.7, "Z_wdot": -14.57,
    "K_pdot": -0.12, "M_qdot": -0.12, "N_rdot": -0.12,
    "X_u": -4.03, "Y_v": -6.22, "Z_w": -5.18, "K_p": -0.07, "M_q": -0.07, "N_r": -0.07,
    "X_uu": -18.18, "Y_vv": -21.66, "Z_ww": -36.99, "K_pp": -1.55, "M_qq": -1.55, "N_rr": -1.55,
    "W-B": -2.0, "eta_z": 2.256,
}


def rows(path):
    out = []
    for line in path.read_text().splitlines():
        if line.strip():
            out.append([float(x) for x in line.split(",")])
    return out


def write(src, out):
    folder = src / "matlab_data" if (src / "matlab_data").is_dir() else src
    pose, thrust = folder / "pose_data.csv", folder / "thrust_data.csv"
    for f in (pose, thrust):
        if not f.is_file():
            raise SystemExit(f"{f}: not found (give the repository's folder or its matlab_data/)")
    pose, thrust = rows(pose), rows(thrust)
    n = min(len(pose), len(thrust))
    out.mkdir(parents=True, exist_ok=True)
    (out / "pipeline.yaml").write_text(PIPELINE)
    per = n // RUNS
    deg = 180.0 / math.pi
    for r in range(RUNS):
        a, b = r * per, (r + 1) * per if r < RUNS - 1 else n
        run = out / "cases" / "pool" / f"run_{r}"
        run.mkdir(parents=True, exist_ok=True)
        role = "validate" if r == RUNS - 1 else "train"
        (run / "run.yaml").write_text(
            f"role: {role}\ndescription: \"simulated BlueROV2 Heavy, rows {a}-{b} of matlab_data\"\n")
        with open(run / "thrust.csv", "w") as f:
            f.write("t,X_N,Y_N,Z_N,K_Nm,M_Nm,N_Nm\n")
            for k in range(a, b):
                f.write(f"{(k - a) * STEP_S:.3f}," + ",".join(f"{x:.6g}" for x in thrust[k][:6]) + "\n")
        with open(run / "nav.csv", "w") as f:
            f.write("t,u_m_s,v_m_s,w_m_s,roll_deg,pitch_deg,yaw_deg,p_dps,q_dps,r_dps\n")
            for k in range(a, b):
                p = pose[k]
                cols = p[3:6] + [x * deg for x in p[0:3]] + [x * deg for x in p[6:9]]
                f.write(f"{(k - a) * STEP_S:.3f}," + ",".join(f"{x:.6g}" for x in cols) + "\n")
    print(f"wrote {out}: {RUNS} runs of {per * STEP_S:.0f} s, the last held out")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--compare", type=Path, metavar="OUT", help="print a built project's coefficients beside the simulator's")
    ap.add_argument("src", type=Path, nargs="?", help="a clone of dream-oyh/6dof-rov-dynamics-forward")
    ap.add_argument("out", type=Path, nargs="?", help="the project folder to write")
    args = ap.parse_args()
    if args.compare:
        compare(args.compare, SIMULATOR)
    elif args.src and args.out:
        write(args.src.resolve(), args.out)
    else:
        ap.error("give SRC OUT, or --compare OUT")


if __name__ == "__main__":
    main()
