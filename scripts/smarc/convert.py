#!/usr/bin/env python3
"""Writes a hydrofit project from a BlueROV2 Heavy's tank runs published with the SAAB / KTH
SMaRC residual-modelling work (github SAABmarine-MEX/saabmarineMEX_learning, folder
`residual_modelling/data_and_plots/dictfiles_plot/`, six `*_data_all.npz` files of 27 May 2025).

The repository has no licence: nothing of it is copied into hydrofit; give the path of a clone
or of that folder, and an output folder outside the repository.

Each file holds one piloted run (ArduSub RC override, manual flight) with motion capture,
averaged by its authors into bins of at least 0.1 s (`generate_data.py`): `timestamps` (the
start of each bin, ns), `real_vel` (u, v, w, p, q, r in the body frame, from the motion
capture's twist), `real_pos` (x, y, z and roll, pitch, yaw, zeroed at the run's start) and
`controls` (the six RC channels as (PWM - 1500) / 400, in ArduSub's order pitch, roll,
throttle, yaw, forward, lateral; the throttle's sign turned so that positive is down).

What this script does, as a user of such a dataset would:
- each bin is placed at its middle (its average belongs there, not at its start);
- the pilot's six axes become the eight thrusters' normalised commands through ArduSub's
  mixing for the "vectored 6DOF" frame (AP_Motors6DOF.cpp: each motor's roll, pitch, yaw,
  throttle, forward and lateral factors), clipped at +-1, written as a CSV log `motors.csv`
  that the run folder's `run.yaml` reads through `vehicle.thrusters` (layout
  `bluerov2_heavy`, the T200's 16 V curve), so hydrofit forms the body wrench itself;
- the motion capture's velocities and attitude become `nav.csv`;
- each run is cut into segments of about 40 s; every fourth segment is held out.

    python3 scripts/smarc/convert.py /path/to/saabmarineMEX_learning /tmp/smarc
    cargo run --release -- build --project /tmp/smarc
    python3 scripts/heldout.py /tmp/smarc
"""

import argparse
import math
from pathlib import Path

import numpy as np

FOLDER = "residual_modelling/data_and_plots/dictfiles_plot"
SEGMENT_S = 40.0
MIN_SEGMENT_S = 20.0

# ArduSub's vectored 6DOF mixing (AP_Motors6DOF.cpp, SUB_FRAME_VECTORED_6DOF): per motor the
# factors of roll, pitch, yaw, throttle (positive up), forward, lateral.
MIXING = np.array([
    [0, 0, 1, 0, -1, 1],
    [0, 0, -1, 0, -1, -1],
    [0, 0, -1, 0, 1, 1],
    [0, 0, 1, 0, 1, -1],
    [1, -1, 0, -1, 0, 0],
    [-1, -1, 0, -1, 0, 0],
    [1, 1, 0, -1, 0, 0],
    [-1, 1, 0, -1, 0, 0],
], dtype=float)

PIPELINE = """\
# BlueROV2 Heavy in a test tank, piloted in six DOF, motion capture (SAAB / KTH SMaRC,
# github SAABmarine-MEX/saabmarineMEX_learning; no licence: not part of hydrofit).
# Written by scripts/smarc/convert.py. Mass and inertia are the commonly quoted BlueROV2
# figures (Wu 2018), not measured for this vehicle; the added mass is identified.
vehicle:
  name: BlueROV2 Heavy (SMaRC tank, 27 May 2025)
  mass_kg: 11.5
  inertia_kg_m2: {xx: 0.16, yy: 0.16, zz: 0.16}
  dofs: [surge, sway, heave, roll, pitch, yaw]
  structure: diagonal
  thrusters:
    layout: bluerov2_heavy
    command: normalised
    curve: t200_16v
stages:
  pool: {kind: pool, inputs: ["cases/pool/*/"]}
  fit: {kind: fit, from: [pool]}
  fit_ols: {kind: fit, from: [pool], settings: {method: ols}}
  validate: {kind: validate, from: [fit, fit_ols, pool]}
  diagnose: {kind: diagnose, from: [fit, pool]}
  report: {kind: report, from: [fit, fit_ols, pool, validate, diagnose]}
"""


def motors(controls):
    """The eight motors' normalised commands from the pilot's six axes (rows of
    pitch, roll, throttle (positive down), yaw, forward, lateral)."""
    pitch, roll, down, yaw, forward, lateral = controls.T
    axes = np.stack([roll, pitch, yaw, -down, forward, lateral])
    return np.clip(MIXING @ axes, -1.0, 1.0).T


def load(path):
    z = np.load(path)
    n = min(len(z["real_vel"]), len(z["controls"]), len(z["real_pos"]), len(z["timestamps"]) - 1)
    start = z["timestamps"].astype(float) / 1e9
    # Each bin's average at the middle of the bin (its end is the next bin's start).
    mid = 0.5 * (start[:n] + start[1:n + 1])
    return mid - mid[0], z["real_vel"][:n], z["real_pos"][:n], z["controls"][:n]


def write_segment(run, t, vel, pos, ctl, role, description):
    run.mkdir(parents=True, exist_ok=True)
    (run / "run.yaml").write_text(
        f"role: {role}\n"
        f"description: \"{description}\"\n"
        "log:\n"
        "  file: motors.csv\n"
        "  command: {topic: motors, fields: [m1, m2, m3, m4, m5, m6, m7, m8]}\n")
    t = t - t[0]
    m = motors(ctl)
    with open(run / "motors.csv", "w") as f:
        f.write("time_s,m1,m2,m3,m4,m5,m6,m7,m8\n")
        for k in range(len(t)):
            f.write(f"{t[k]:.4f}," + ",".join(f"{x:.5f}" for x in m[k]) + "\n")
    deg = 180.0 / math.pi
    with open(run / "nav.csv", "w") as f:
        f.write("t,u_m_s,v_m_s,w_m_s,roll_deg,pitch_deg,yaw_deg,p_dps,q_dps,r_dps\n")
        for k in range(len(t)):
            cols = list(vel[k, :3]) + [x * deg for x in pos[k, 3:6]] + [x * deg for x in vel[k, 3:6]]
            f.write(f"{t[k]:.4f}," + ",".join(f"{x:.6g}" for x in cols) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("src", type=Path, help="a clone of SAABmarine-MEX/saabmarineMEX_learning, or its dictfiles_plot folder")
    ap.add_argument("out", type=Path, help="the project folder to write (outside hydrofit)")
    args = ap.parse_args()
    src = args.src / FOLDER if (args.src / FOLDER).is_dir() else args.src
    files = sorted(src.glob("*_data_all.npz"))
    if not files:
        raise SystemExit(f"{src}: no *_data_all.npz files")
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "pipeline.yaml").write_text(PIPELINE)
    index = 0
    for path in files:
        t, vel, pos, ctl = load(path)
        name = path.name.replace("rosbag2_2025_05_27-", "").replace("_data_all.npz", "")
        pieces = max(1, int(t[-1] // SEGMENT_S))
        edges = np.linspace(0.0, t[-1], pieces + 1)
        for s in range(pieces):
            keep = (t >= edges[s]) & (t < edges[s + 1])
            if t[keep][-1] - t[keep][0] < MIN_SEGMENT_S:
                continue
            role = "validate" if index % 4 == 3 else "train"
            desc = f"{name}, {edges[s]:.0f}-{edges[s + 1]:.0f} s"
            write_segment(args.out / "cases" / "pool" / f"{name}_{s}", t[keep], vel[keep],
                          pos[keep], ctl[keep], role, desc)
            index += 1
    print(f"wrote {args.out}: {index} runs from {len(files)} files, every fourth held out")


if __name__ == "__main__":
    main()
