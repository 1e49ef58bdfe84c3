#!/usr/bin/env python3
"""Convert the ExjobbROV pool-test bags (BlueROV, 2016) into a hydrofit project.

    python3 scripts/exjobb/convert.py inspect BAG_DIR         # topics, types, counts, rates
    python3 scripts/exjobb/convert.py BAG_DIR OUT_PROJECT     # write pipeline.yaml + cases/pool/

The bags are not part of this repository (their source has no licence); see README.md here.
Needs: pip install rosbags numpy
"""
import sys
from pathlib import Path

import numpy as np
from rosbags.rosbag1 import Reader
from rosbags.typesys import Stores, get_typestore

TYPESTORE = get_typestore(Stores.ROS1_NOETIC)

# --- Thesis data (facts, not prose) -------------------------------------------------------
# Thrust per thruster [N] against the normalised control signal u = (PWM - 1500 us) / 400 us,
# T200 thrusters; thesis appendix "Thruster Mapping" (Documents/Master/sections/
# measuredthrust.txt, included by thrustmapping.tex). The MATLAB copies of the table
# (simulink/Estimation*/thrusterLookup.m) swap the first and third values of the reverse end
# (-40.0337 / -40.0788); the thesis appendix is used here. The PWM -> u scaling is the one of
# simulink/Estimation/getTestData.m.
THRUST_U = np.round(np.arange(-40, 41) * 0.025, 4)
THRUST_N = np.array([
    -40.0788, -40.0788, -40.0337, -37.5428, -36.6092, -35.4971, -33.7623, -32.3835, -31.2263,
    -29.9809, -28.5128, -27.6234, -26.5554, -24.7765, -23.1751, -22.1522, -21.3510, -19.5280,
    -18.4600, -17.3480, -16.1025, -14.6345, -13.0781, -12.1877, -10.9874, -10.0528, -8.8966,
    -7.7404, -6.8058, -6.0497, -5.1151, -4.2698, -3.4696, -2.7135, -1.8682, -1.1121, -0.5335,
    -0.2667, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5786, 1.1121, 1.8240, 2.5801, 3.4255, 4.0923, 5.1151,
    6.2272, 7.0284, 8.2739, 9.2526, 10.8089, 12.2328, 13.6558, 14.9904, 16.4585, 17.7039,
    19.2161, 20.5508, 21.7521, 23.6644, 24.7324, 26.4221, 27.7126, 29.6249, 31.3156, 32.8729,
    33.8065, 34.2517, 37.0534, 38.6549, 39.2776, 41.1458, 42.9257, 44.7938, 47.1062, 48.0408,
    49.9531])
assert len(THRUST_N) == len(THRUST_U) == 81

# Thruster geometry: thesis ch. "Modelling the ROV", sec. "Actuators" (eq. actuatorGeometry,
# the matrix T in tau = T f; the expanded right-hand side printed after it has typos, the
# matrix agrees with the component equations p_dot, q_dot, r_dot) and the moment arms of
# table "tab:parameterConstants" (sec. "Estimated Parameters"). Body frame of the thesis:
# x forward, y starboard, z down, origin at the CG (SNAME/Fossen, same as hydrofit).
#   thrusters 1, 2: vertical, forward, 1 port / 2 starboard; positive thrust pushes up (-z)
#   thrusters 3, 4: horizontal, 3 port / 4 starboard; positive thrust pushes forward (+x)
#   thruster 5:     vertical, aft on the centre line; positive thrust pushes up (-z)
#   thruster 6:     lateral; positive thrust pushes to port (-y)
LX1, LX2, LX5 = 0.19, 0.19, 0.17
LY1, LY2, LY3, LY4 = 0.11, 0.11, 0.11, 0.11
LZ6 = 0.0  # the thesis fixed it to zero (its measured arm made the roll fit worse)
GEOMETRY = np.array([  # rows X Y Z K M N, columns thrusters 1..6
    [0, 0, 1, 1, 0, 0],
    [0, 0, 0, 0, 0, -1],
    [-1, -1, 0, 0, -1, 0],
    [LY1, -LY2, 0, 0, 0, LZ6],
    [LX1, LX2, 0, 0, -LX5, 0],
    [0, 0, LY3, -LY4, 0, 0],
], dtype=float)

# Constants of the same table.
MASS_KG = 6.621
G = 9.82
RHO = 1000.0
# Roll/pitch/yaw inertia INCLUDING added inertia (A_p = I_x - K_pdot, B_q, C_r): the thesis
# identifies only these sums; it gives no rigid-body part.
INERTIA_TOTAL = {"xx": 0.8337, "yy": 0.7987, "zz": 1.1250}
# hydrofit's vehicle inertia is the RIGID-BODY part (the added inertia is identified). With no
# CAD value at hand, a uniform box of the frame's size (about 0.45 x 0.34 x 0.25 m, 6.621 kg):
# I_xx = m (b^2 + h^2) / 12 and so on. Put the vehicle's CAD inertia here when it is known.
BOX_M = (0.45, 0.34, 0.25)
INERTIA_RIGID = {
    "xx": round(MASS_KG * (BOX_M[1] ** 2 + BOX_M[2] ** 2) / 12, 3),
    "yy": round(MASS_KG * (BOX_M[0] ** 2 + BOX_M[2] ** 2) / 12, 3),
    "zz": round(MASS_KG * (BOX_M[0] ** 2 + BOX_M[1] ** 2) / 12, 3),
}

# --- Run selection --------------------------------------------------------------------------
# Closed-loop controller tests of 23 and 25 May 2016 (same EKF and firmware as HEAD of the
# thesis repository). Name codes of the thesis authors: sinP/sinQ/sinR = sine reference on the
# roll/pitch/yaw RATE, sinPhi/sinTheta = sine on the roll/pitch ANGLE, sinAll = all three,
# step* = steps, A = amplitude code, F05/Hz05 = 0.5 Hz.
RUNS = [
    # (bag file, role, end [s of bag time] or None, description). Ends chosen by inspection
    # (the thesis also cut each test by hand): after them the vehicle was grabbed or lifted
    # (rate spikes the commands do not explain) or its thrusters stopped while the controller
    # kept commanding (commands sweep or wind up, rates stay ~0).
    ("sinAllA1hz05_2016-05-23-15-28-28.bag", "train", 14.9, "sine references on p, q and r together"),
    ("sinAllAttitudeA1_2016-05-25-09-06-44.bag", "train", 16.4, "sine references on roll, pitch and yaw angle together"),
    ("stepThetaPhi_2016-05-25-09-16-21.bag", "train", 18.1, "steps on the roll and pitch angle references"),
    ("sinPhiA1F05_2016-05-25-08-47-12.bag", "train", None, "sine on the roll angle reference, 0.5 Hz"),
    ("sinThetaA1F05_2016-05-25-08-54-21.bag", "train", None, "sine on the pitch angle reference, 0.5 Hz"),
    ("sinQA1Hz05_2016-05-23-15-27-20.bag", "train", 20.5, "sine on the pitch rate reference, 0.5 Hz"),
    ("sinRA1Hz05_2016-05-23-15-23-40.bag", "train", 20.4, "sine on the yaw rate reference, 0.5 Hz"),
    ("stepRS3E10_2016-05-25-08-33-30.bag", "train", 26.0, "steps on the yaw rate reference"),
    ("sinAllA1F05_2016-05-25-08-37-44.bag", "validate", None, "sine references on p, q and r together, 0.5 Hz"),
    ("stepAllAttitude_2016-05-25-09-14-26.bag", "validate", 16.2, "steps on the roll, pitch and yaw angle references"),
    ("sinPhiA1F05_2016-05-25-08-47-49.bag", "validate", None, "sine on the roll angle reference, 0.5 Hz (repeat)"),
    ("sinQA1F05_2016-05-25-08-26-38.bag", "validate", 23.7, "sine on the pitch rate reference, 0.5 Hz"),
]

T_THRUSTERS = "rovio/thrusters"          # std_msgs/UInt16MultiArray, six PWM values [us]
T_STATES = "sensor_fusion/states"        # std_msgs/Float64MultiArray, EKF output (see below)
T_PRESSURE = "rovio/water_pressure/data"  # std_msgs/Float32, gauge pressure [Pa]


def read_bag(path):
    """{topic (no leading slash): (t [s, receive time from bag start], data [n, k])}."""
    out = {}
    with Reader(path) as r:
        t0 = r.start_time
        for conn, t, raw in r.messages():
            msg = TYPESTORE.deserialize_ros1(raw, conn.msgtype)
            data = np.atleast_1d(np.asarray(msg.data, dtype=float))
            out.setdefault(conn.topic.lstrip("/"), []).append(((t - t0) * 1e-9, data))
    res = {}
    for k, v in out.items():
        width = max(len(d) for _, d in v)
        rows = [(t, d) for t, d in v if len(d) == width]
        res[k] = (np.array([t for t, _ in rows]), np.array([d for _, d in rows]))
    return res


def inspect(bag_dir):
    for p in sorted(Path(bag_dir).glob("*.bag*")):
        try:
            with Reader(p) as r:
                dur = r.duration * 1e-9
                print(f"{p.name}  {dur:.1f} s")
                for c in r.connections:
                    n = c.msgcount
                    print(f"    {c.topic:32s} {c.msgtype:34s} {n:6d} msgs  {n / max(dur, 1e-9):6.1f} Hz")
        except Exception as e:  # unreadable or unindexed (.bag.active) files
            print(f"{p.name}  UNREADABLE: {e}")


def thrust_newton(pwm):
    u = np.clip((pwm - 1500.0) / 400.0, -1.0, 1.0)
    return np.interp(u, THRUST_U, THRUST_N)


def write_csv(path, header, cols, fmt):
    arr = np.column_stack(cols)
    np.savetxt(path, arr, delimiter=",", header=",".join(header), comments="", fmt=fmt)


def convert_run(bag, out_dir, role, end, description):
    d = read_bag(bag)
    tt, pwm = d[T_THRUSTERS]
    ts, st = d[T_STATES]
    tp, pr = d[T_PRESSURE]
    # Run start. Every bag opens with a few seconds in which the logged PWM holds a stale,
    # wound-up command (up to full thrust, e.g. K = 6 N m) while the vehicle sits still (rates of
    # a few deg/s): the thrusters were not yet running. Then the thruster topic pauses ~0.8 s
    # (the controller restarting) and resumes near neutral. The run starts at the first command
    # after that pause with every PWM within 60 us of neutral; it ends at `end` (RUNS) or with
    # the last command.
    early = np.flatnonzero(tt < tt[0] + 5.0)
    gap = early[np.argmax(np.diff(tt[early]))]
    calm = np.flatnonzero((np.abs(pwm - 1500).max(axis=1) <= 60) & (np.arange(len(tt)) > gap))
    i0 = calm[0] if len(calm) else gap + 1
    i1 = len(tt) if end is None else np.searchsorted(tt, end, side="right")
    t0, t1 = tt[i0], tt[i1 - 1]
    tt, pwm = tt[i0:i1], pwm[i0:i1]
    tau = thrust_newton(pwm) @ GEOMETRY.T  # [n, 6] body-frame X Y Z K M N
    out_dir.mkdir(parents=True, exist_ok=True)
    write_csv(out_dir / "thrust.csv", ["t", "X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm"],
              [tt - t0] + [tau[:, i] for i in range(6)], "%.4f")
    # EKF state message (catkin_ws/src/sensorfusion/src/sensorfusion.cpp, Ekf::sendStates):
    # [roll, pitch, yaw, p, q, r, bias_p, bias_q, bias_r, depth]; ZYX Euler angles of a
    # NED-to-body (FRD) quaternion, rates in rad/s about the FRD body axes, gyro bias removed.
    # Already hydrofit's convention: no sign change.
    k = (ts >= t0) & (ts <= t1)
    ang = np.degrees(st[k, 0:3])
    ang[:, 2] = np.degrees(np.unwrap(st[k, 2]))  # continuous heading
    rates = np.degrees(st[k, 3:6])
    write_csv(out_dir / "nav.csv",
              ["t", "roll_deg", "pitch_deg", "yaw_deg", "p_dps", "q_dps", "r_dps"],
              [ts[k] - t0] + [ang[:, i] for i in range(3)] + [rates[:, i] for i in range(3)],
              "%.4f")
    # Gauge pressure of the external sensor (barometer offset removed on board) -> depth of the
    # sensor (at the stern), positive down.
    k = (tp >= t0) & (tp <= t1)
    write_csv(out_dir / "depth.csv", ["t", "depth_m"],
              [tp[k] - t0, pr[k, 0] / (RHO * G)], "%.4f")
    (out_dir / "run.yaml").write_text(
        f"role: {role}\n"
        f"description: \"{description}; BlueROV (6.62 kg, six T200), ExjobbROV bag "
        f"{Path(bag).name}, {t0:.2f}-{t1:.2f} s of the bag (before: stale commands, thrusters "
        f"not running{'' if end is None else '; after: vehicle handled or thrusters stopped'}); "
        f"closed-loop attitude/rate controller, thrust from logged PWM via the thesis thrust "
        f"table; attitude and rates from the on-board EKF\"\n")
    return dict(dropped_s=t0, duration=t1 - t0, n_thrust=len(tt), pwm_min=pwm.min(), pwm_max=pwm.max(),
                tau_std=tau[:, 3:].std(0), rate_std_dps=rates.std(0))


PIPELINE = """\
# BlueROV (first version, six T200 thrusters) of the 2016 ExjobbROV master's thesis, identified
# in roll, pitch and yaw from closed-loop pool tests. Written by scripts/exjobb/convert.py.
vehicle:
  name: BlueROV 2016 (ExjobbROV thesis)
  mass_kg: {mass}
  # Rigid-body inertia of a uniform box of the frame's size (no CAD value at hand); the added
  # inertia K_pdot, M_qdot, N_rdot is identified. The thesis's totals (rigid + added) are
  # {totals}.
  inertia_kg_m2: {{xx: {xx}, yy: {yy}, zz: {zz}}}
  dofs: [roll, pitch, yaw]
  structure: diagonal
  # Thruster offsets / unmodelled CG offset: the controller holds steady non-zero moments.
  constant_force: [roll, pitch, yaw]
stages:
  pool:
    kind: pool
    inputs: ["cases/pool/*/"]
  # hydrofit's default pool fit (the prediction-error method: least squares, then the
  # simulation error of the training runs minimised).
  fit:
    kind: fit
    from: [pool]
  # Least squares on the equation error alone, for comparison.
  fit_ols:
    kind: fit
    from: [pool]
    settings: {{method: ols}}
  validate:
    kind: validate
    from: [fit, fit_ols, pool]
  report:
    kind: report
    from: [fit, fit_ols, pool, validate]
"""


def convert(bag_dir, out):
    bag_dir, out = Path(bag_dir), Path(out)
    missing = [b for b, _, _, _ in RUNS if not (bag_dir / b).exists()]
    if missing:
        sys.exit(f"missing bags in {bag_dir}: {', '.join(missing)}")
    out.mkdir(parents=True, exist_ok=True)
    totals = ", ".join(f"{k} {v}" for k, v in INERTIA_TOTAL.items())
    (out / "pipeline.yaml").write_text(PIPELINE.format(mass=MASS_KG, totals=totals, **INERTIA_RIGID))
    for bag, role, end, desc in RUNS:
        stem, date_time = bag[:-4].split("_2016-")
        name = f"{stem}_{date_time[6:].replace('-', '')}"  # e.g. sinPhiA1F05_084712
        info = convert_run(bag_dir / bag, out / "cases" / "pool" / name, role, end, desc)
        print(f"{name:24s} {role:8s} drop {info['dropped_s']:4.2f} s, keep {info['duration']:4.1f} s  PWM {info['pwm_min']:.0f}-"
              f"{info['pwm_max']:.0f}  std K,M,N {np.round(info['tau_std'], 2)} N m  "
              f"std p,q,r {np.round(info['rate_std_dps'], 1)} deg/s")


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "inspect":
        inspect(sys.argv[2])
    elif len(sys.argv) == 3:
        convert(sys.argv[1], sys.argv[2])
    else:
        sys.exit(__doc__)
