#!/usr/bin/env python3
"""The thesis's open-loop yaw runs: a per-DOF output-error fit, and the thesis's own tables.

    pip install rosbags numpy scipy
    python3 scripts/exjobb/open_loop_yaw.py BAG_DIR [OUT.json]

The April 2016 bags `yaw_1` .. `yaw_5` drive the two horizontal thrusters (3, 4) open loop with
a random telegraph of +-280 us, so the yaw moment N = 0.11 (f3 - f4) jumps between about
-6.8, 0 and +6.8 N m every 0.2-0.8 s: the kind of run a thesis fixes its yaw damping from.
Trained on yaw_1, 2, 3, 5, held out yaw_4 (the longest), the same split as
`project.py --open-loop-yaw`. For r (the EKF's `sensor_fusion/states[5]`) it fits
    I r' = n + N_r r + N_rr |r| r + N_0,   n' = (N - n) / T   (a command lag T)
by scipy.optimize.least_squares on the simulated-minus-logged rate, each run simulated from its
first sample (Euler-Heun at 50 Hz, the command held between messages), and scores the held-out
run by NMAE = mean|r_model - r| / mean|r| (predicting rest scores 1), also for the yaw rows of
the thesis's three tables (chapter "Parameter Estimation"): its prediction-error estimate with
the angles as inputs (structure as hydrofit's), the one with accelerations as outputs, and the
EKF estimate it adopted (tab:parameterConstants). Reads the bags; copies nothing.
"""
import json
import sys
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

sys.path.insert(0, str(Path(__file__).resolve().parent))
import project  # noqa: E402  (the thrust table)

DT = 0.02
ARM_M = 0.11  # l_y of thrusters 3 and 4, thesis tab:parameterConstants
# (bag, role, span in s from the bag's start): from the first thruster message to 0.2 s after
# the last non-neutral one.
RUNS = [
    ("yaw_1_2016-04-18-13-44-26.bag", "train", (0.86, 25.45)),
    ("yaw_2_2016-04-18-13-46-47.bag", "train", (0.41, 20.42)),
    ("yaw_3_2016-04-18-13-50-03.bag", "train", (0.66, 14.45)),
    ("yaw_5_2016-04-18-13-56-59.bag", "train", (0.44, 21.40)),
    ("yaw_4_2016-04-18-13-52-57.bag", "validate", (0.59, 31.89)),
]
# Yaw rows of the thesis's tables: total inertia C_r (rigid + added), N_r, N_r|r|.
THESIS = {
    "prediction error, angles as inputs (tab:ResultEstimAngular, left)": (0.9546, -2.7838, -0.6751),
    "prediction error, accelerations as outputs (tab:ResultEstimAngular, right)": (1.0981, -2.9364, -2.1843),
    "EKF, adopted (tab:parameterConstants; its start values 1, -1, -1)": (1.1250, -1.0280, -1.0249),
}


def load(bag, span):
    """Time grid, yaw moment N from the PWM, and the EKF's r on the grid."""
    from rosbags.rosbag1 import Reader
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    thr, states = [], []
    with Reader(bag) as r:
        for c, t, raw in r.messages():
            if c.topic.lstrip("/") not in ("rovio/thrusters", "sensor_fusion/states"):
                continue
            m = store.deserialize_ros1(raw, c.msgtype)
            row = ((t - r.start_time) * 1e-9, np.asarray(m.data, dtype=float))
            (thr if "thrusters" in c.topic else states).append(row)
    grid = np.arange(span[0], span[1], DT)
    t_cmd = np.array([x[0] for x in thr])
    pwm = np.array([x[1] for x in thr])
    held = np.clip(np.searchsorted(t_cmd, grid, side="right") - 1, 0, len(t_cmd) - 1)
    u = np.clip((pwm[held] - 1500.0) / 400.0, -1.0, 1.0)
    f = np.interp(u, project.THRUST_U, project.THRUST_N)
    n = ARM_M * (f[:, 2] - f[:, 3])
    t_s = np.array([x[0] for x in states])
    r = np.interp(grid, t_s, [x[1][5] for x in states])
    return n, r


def simulate(p, n_cmd, r0):
    inertia, lin, quad, const, lag = p
    r = np.empty_like(n_cmd)
    r[0] = x = r0
    n = n_cmd[0]
    for k in range(1, len(n_cmd)):
        n = n + (n_cmd[k - 1] - n) * (1.0 - np.exp(-DT / lag)) if lag > 1e-3 else n_cmd[k - 1]
        acc = lambda v: (n + lin * v + quad * abs(v) * v + const) / inertia  # noqa: E731
        pred = x + DT * acc(x)
        x = x + DT / 2.0 * (acc(x) + acc(pred))
        r[k] = x
    return r


def nmae(p, runs):
    return float(np.mean([np.mean(abs(simulate(p, n, r[0]) - r)) / np.mean(abs(r)) for n, r in runs]))


def main(bag_dir, out):
    data = {role: [] for role in ("train", "validate")}
    for bag, role, span in RUNS:
        data[role].append(load(str(Path(bag_dir) / bag), span))
    train, held = data["train"], data["validate"]

    def residual(p):
        return np.concatenate([simulate(p, n, r[0]) - r for n, r in train])

    result = {"fits": {}, "thesis": {}}
    # (inertia, N_r, N_rr, N_0, lag) start and bounds; "inertia fixed" pins C_r near the
    # thesis's 1.125 to show the damping does not follow the inertia.
    for name, x0, lo, hi in [
        ("inertia free", [0.5, -1.0, -0.5, 0.0, 0.1], [0.05, -20, -20, -3, 0], [5, 0, 0, 3, 0.5]),
        ("inertia at the thesis's 1.125", [1.125, -1.0, -0.5, 0.0, 0.1], [1.12, -20, -20, -3, 0], [1.13, 0, 0, 3, 0.5]),
    ]:
        fit = least_squares(residual, x0, bounds=(lo, hi))
        p = [float(v) for v in fit.x]
        result["fits"][name] = {
            "I": p[0], "N_r": p[1], "N_rr": p[2], "N_0": p[3], "lag_s": p[4],
            "nmae_train": nmae(p, train), "nmae_validate": nmae(p, held),
        }
        print(f"fit, {name}: I {p[0]:.3f}  N_r {p[1]:.3f}  N_rr {p[2]:.3f}  N_0 {p[3]:.3f}  "
              f"lag {p[4]:.3f} s  NMAE train {nmae(p, train):.3f}  held out {nmae(p, held):.3f}")
    for name, (inertia, lin, quad) in THESIS.items():
        p = [inertia, lin, quad, 0.0, 0.0]
        result["thesis"][name] = {"nmae_train": nmae(p, train), "nmae_validate": nmae(p, held)}
        print(f"thesis, {name}: NMAE train {nmae(p, train):.3f}  held out {nmae(p, held):.3f}")
    if out:
        Path(out).write_text(json.dumps(result, indent=2))


if __name__ == "__main__":
    if len(sys.argv) not in (2, 3):
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2] if len(sys.argv) == 3 else None)
