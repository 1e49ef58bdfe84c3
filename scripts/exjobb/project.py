#!/usr/bin/env python3
"""Write a hydrofit project that builds the ExjobbROV pool-test bags (BlueROV, 2016) directly.

    python3 scripts/exjobb/project.py BAG_DIR OUT_PROJECT [--open-loop-yaw | --unseen]
    cargo run --release -- build --project OUT_PROJECT

With --open-loop-yaw the project is the thesis's April open-loop yaw runs instead (`yaw_1` ..
`yaw_5`: a random telegraph on the two horizontal thrusters), identified in yaw alone, with
the split of open_loop_yaw.py. With --unseen every run of RUNS trains and the 34 other
closed-loop May runs of UNSEEN are held out.

No converter: each run folder's run.yaml points at its bag (by absolute path; the bags are not
copied, their source has no licence) with the span of the bag that is the run, and names the
topics and fields of the command, attitude, rates and depth. pipeline.yaml describes the
thrusters once (the thesis's geometry and thrust table), so the six logged PWM values become
the body wrench inside hydrofit. Python's standard library is all this needs.
"""
import sys
from pathlib import Path

# Thrust per thruster [N] against the normalised command u = (PWM - 1500 us) / 400 us; thesis
# appendix "Thruster Mapping" (Documents/Master/sections/measuredthrust.txt), 81 points.
THRUST_N = [
    -40.0788, -40.0788, -40.0337, -37.5428, -36.6092, -35.4971, -33.7623, -32.3835, -31.2263,
    -29.9809, -28.5128, -27.6234, -26.5554, -24.7765, -23.1751, -22.1522, -21.3510, -19.5280,
    -18.4600, -17.3480, -16.1025, -14.6345, -13.0781, -12.1877, -10.9874, -10.0528, -8.8966,
    -7.7404, -6.8058, -6.0497, -5.1151, -4.2698, -3.4696, -2.7135, -1.8682, -1.1121, -0.5335,
    -0.2667, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5786, 1.1121, 1.8240, 2.5801, 3.4255, 4.0923, 5.1151,
    6.2272, 7.0284, 8.2739, 9.2526, 10.8089, 12.2328, 13.6558, 14.9904, 16.4585, 17.7039,
    19.2161, 20.5508, 21.7521, 23.6644, 24.7324, 26.4221, 27.7126, 29.6249, 31.3156, 32.8729,
    33.8065, 34.2517, 37.0534, 38.6549, 39.2776, 41.1458, 42.9257, 44.7938, 47.1062, 48.0408,
    49.9531]
THRUST_U = [round(k * 0.025, 4) for k in range(-40, 41)]

MASS_KG = 6.621
# Rigid-body inertia of a uniform box of the frame's size (0.45 x 0.34 x 0.25 m); the added
# inertia is identified. The thesis gives only rigid + added totals (0.834, 0.799, 1.125).
BOX_M = (0.45, 0.34, 0.25)
INERTIA = {
    "xx": round(MASS_KG * (BOX_M[1] ** 2 + BOX_M[2] ** 2) / 12, 3),
    "yy": round(MASS_KG * (BOX_M[0] ** 2 + BOX_M[2] ** 2) / 12, 3),
    "zz": round(MASS_KG * (BOX_M[0] ** 2 + BOX_M[1] ** 2) / 12, 3),
}

# (bag, role, span in seconds from the bag's start, description). Each run starts at the
# first thruster command after the controller's restart (a ~0.8 s pause in the thruster
# topic) with every PWM within 60 us of neutral; before it the log holds stale, wound-up
# commands while the thrusters were not running. Ends where the vehicle was handled or the
# thrusters stopped, chosen by inspection (the thesis also cut its tests by hand).
RUNS = [
    ("sinAllA1hz05_2016-05-23-15-28-28.bag", "train", [1.894, 14.894], "sine references on p, q and r together"),
    ("sinAllAttitudeA1_2016-05-25-09-06-44.bag", "train", [1.941, 16.391], "sine references on roll, pitch and yaw angle together"),
    ("stepThetaPhi_2016-05-25-09-16-21.bag", "train", [2.640, 18.100], "steps on the roll and pitch angle references"),
    ("sinPhiA1F05_2016-05-25-08-47-12.bag", "train", [3.539, 16.829], "sine on the roll angle reference, 0.5 Hz"),
    ("sinThetaA1F05_2016-05-25-08-54-21.bag", "train", [1.737, 21.747], "sine on the pitch angle reference, 0.5 Hz"),
    ("sinQA1Hz05_2016-05-23-15-27-20.bag", "train", [2.966, 20.496], "sine on the pitch rate reference, 0.5 Hz"),
    ("sinRA1Hz05_2016-05-23-15-23-40.bag", "train", [1.941, 20.391], "sine on the yaw rate reference, 0.5 Hz"),
    ("stepRS3E10_2016-05-25-08-33-30.bag", "train", [2.515, 25.995], "steps on the yaw rate reference"),
    ("sinAllA1F05_2016-05-25-08-37-44.bag", "validate", [2.948, 24.498], "sine references on p, q and r together, 0.5 Hz"),
    ("stepAllAttitude_2016-05-25-09-14-26.bag", "validate", [2.168, 16.199], "steps on the roll, pitch and yaw angle references"),
    ("sinPhiA1F05_2016-05-25-08-47-49.bag", "validate", [1.635, 22.435], "sine on the roll angle reference, 0.5 Hz (repeat)"),
    ("sinQA1F05_2016-05-25-08-26-38.bag", "validate", [2.240, 23.699], "sine on the pitch rate reference, 0.5 Hz"),
]

# Closed-loop runs of 23 and 25 May 2016 outside RUNS, held out by --unseen: every sine and
# step test whose roll and pitch stay under 60 deg and that moves at all (README, "Runs the fit
# never saw"). Spans by the rule of RUNS for the start; each ends 2 s before the last logged
# command, not cut by inspection, so some end with the vehicle being handled.
UNSEEN = [
    ("sinAllA05Hz05_2016-05-23-15-30-25.bag", [2.492, 15.342]),
    ("sinAllA05Hz05_2016-05-23-15-31-03.bag", [2.395, 22.505]),
    ("sinAllAttitudeA05_2016-05-25-09-08-39.bag", [2.114, 23.944]),
    ("sinAllAttitudeA05_2016-05-25-09-12-06.bag", [2.116, 21.766]),
    ("sinAllAttitudeA1_2016-05-25-09-06-05.bag", [2.250, 16.520]),
    ("sinAllAttitudeA1_2016-05-25-09-13-13.bag", [1.909, 23.080]),
    ("sinPA1F05_2016-05-25-08-24-36.bag", [3.944, 12.551]),
    ("sinPNewA05Hz05_2016-05-23-15-19-38.bag", [2.483, 21.383]),
    ("sinPa05hz05_2016-05-23-15-13-18.bag", [1.565, 21.505]),
    ("sinPhiA05F05_2016-05-25-08-48-58.bag", [1.717, 23.767]),
    ("sinPhiA05F05_2016-05-25-08-49-50.bag", [1.982, 22.023]),
    ("sinPhiA1F05_2016-05-25-08-40-17.bag", [1.951, 23.971]),
    ("sinPsiA05F05_2016-05-25-09-00-24.bag", [2.707, 29.707]),
    ("sinPsiA1F05_2016-05-25-08-59-00.bag", [2.260, 24.400]),
    ("sinQA05F05_2016-05-25-08-28-01.bag", [2.589, 24.989]),
    ("sinQNewA05Hz05_2016-05-23-15-20-56.bag", [4.122, 17.832]),
    ("sinQa05hz05_2016-05-23-15-10-00.bag", [2.387, 21.507]),
    ("sinRA05F05_2016-05-25-08-29-57.bag", [1.968, 19.918]),
    ("sinRA1F05_2016-05-25-08-30-43.bag", [2.599, 21.210]),
    ("sinRA1Hz05_2016-05-23-15-23-08.bag", [3.501, 13.420]),
    ("sinRNewA05Hz05_2016-05-23-15-21-51.bag", [2.448, 11.877]),
    ("sinRa05hz05_2016-05-23-15-07-27.bag", [2.561, 16.231]),
    ("sinRa05hz05_2016-05-23-15-08-10.bag", [7.858, 32.728]),
    ("sinThetaA05F05_2016-05-25-08-55-21.bag", [3.426, 22.836]),
    ("stepAllAttitude_2016-05-25-09-15-24.bag", [1.727, 14.367]),
    ("stepPhiS3E10_2016-05-25-08-51-21.bag", [2.740, 20.160]),
    ("stepPhiS3E10_2016-05-25-08-52-37.bag", [2.996, 25.846]),
    ("stepPsiS3E10_2016-05-25-09-02-58.bag", [1.944, 23.184]),
    ("stepPsiS3E10_2016-05-25-09-04-01.bag", [2.520, 34.380]),
    ("stepRS3E10_2016-05-25-08-32-35.bag", [3.412, 29.042]),
    ("stepRS3E10_2016-05-25-08-34-41.bag", [3.881, 13.891]),
    ("stepRS3E10_2016-05-25-08-35-17.bag", [2.259, 42.519]),
    ("stepRs3e10_2016-05-23-13-59-06.bag", [2.168, 19.778]),
    ("stepThetaS3E10_2016-05-25-08-56-31.bag", [2.027, 16.418]),
    ("stepThetaS3E10_2016-05-25-08-57-15.bag", [3.816, 20.416]),
]

PIPELINE = """\
# BlueROV (first version, six T200 thrusters) of the 2016 ExjobbROV master's thesis, identified
# in roll, pitch and yaw from closed-loop pool tests, read from its ROS 1 bags.
# Written by scripts/exjobb/project.py.
vehicle:
  name: BlueROV 2016 (ExjobbROV thesis)
  mass_kg: {mass}
  inertia_kg_m2: {{xx: {xx}, yy: {yy}, zz: {zz}}}
  dofs: [roll, pitch, yaw]
  structure: diagonal
  # Thruster offsets and an unmodelled CG offset: the controller holds steady moments.
  constant_force: [roll, pitch, yaw]
  # The thesis's thrusters: 1, 2 vertical front (port, starboard), 3, 4 horizontal (port,
  # starboard), 5 vertical aft, 6 lateral; its geometry (eq. actuatorGeometry, arms 0.19,
  # 0.17, 0.11 m) is the layout bluerov1_thesis. Thrust against u = (PWM - 1500) / 400: the
  # thesis's measured table.
  thrusters:
    layout: bluerov1_thesis
    command: pwm
    curve:
      input: {u}
      thrust_n: {n}
stages:
  pool:
    kind: pool
    inputs: ["cases/pool/*/"]
  fit:
    kind: fit
    from: [pool]
  fit_ols:
    kind: fit
    from: [pool]
    settings: {{method: ols}}
  validate:
    kind: validate
    from: [fit, fit_ols, pool]
  diagnose:
    kind: diagnose
    from: [fit, pool]
  report:
    kind: report
    from: [fit, fit_ols, pool, validate, diagnose]
"""

RUN = """\
role: {role}
description: "{description}; BlueROV 2016 (ExjobbROV), closed-loop attitude and rate controller"
log:
  file: {bag}
  span_s: [{a}, {b}]
  # rovio/thrusters: six PWM values, us (std_msgs/UInt16MultiArray).
  command: {{topic: rovio/thrusters, fields: ["data[0..6]"]}}
  # sensor_fusion/states: the on-board EKF, [roll, pitch, yaw, p, q, r, bias_p, bias_q,
  # bias_r, depth], zyx Euler angles of the FRD body in NED and body rates, rad and rad/s.
  attitude: {{topic: sensor_fusion/states, fields: ["data[0..3]"]}}
  rates: {{topic: sensor_fusion/states, fields: ["data[3..6]"]}}
  # Gauge pressure of the external sensor, Pa: the depth of the sensor (at the stern).
  depth: {{topic: rovio/water_pressure/data, fields: [data], unit: pa}}
"""


def open_loop_yaw():
    """The April open-loop yaw runs (open_loop_yaw.py's RUNS) as RUNS rows, and the pipeline
    in yaw alone (roll and pitch barely move; the thesis's geometry gives thrusters 3 and 4 no
    pitch arm)."""
    import open_loop_yaw as o

    runs = [(bag, role, span, "random telegraph on thrusters 3 and 4") for bag, role, span in o.RUNS]
    pipeline = PIPELINE.replace("dofs: [roll, pitch, yaw]", "dofs: [yaw]")
    pipeline = pipeline.replace("constant_force: [roll, pitch, yaw]", "constant_force: [yaw]")
    pipeline = pipeline.replace("# in roll, pitch and yaw from closed-loop", "# in yaw from open-loop")
    return runs, pipeline


def unseen():
    """Every run of RUNS for training, the runs of UNSEEN held out."""
    runs = [(bag, "train", span, desc) for bag, _, span, desc in RUNS]
    runs += [(bag, "validate", span, "a run the fit never saw") for bag, span in UNSEEN]
    return runs, PIPELINE


def main(bag_dir, out, mode):
    bag_dir, out = Path(bag_dir).resolve(), Path(out)
    yaw = mode == "--open-loop-yaw"
    runs, pipeline = {"--open-loop-yaw": open_loop_yaw, "--unseen": unseen}.get(mode, lambda: (RUNS, PIPELINE))()
    missing = [b for b, _, _, _ in runs if not (bag_dir / b).exists()]
    if missing:
        sys.exit(f"missing bags in {bag_dir}: {', '.join(missing)}")
    out.mkdir(parents=True, exist_ok=True)
    (out / "pipeline.yaml").write_text(pipeline.format(mass=MASS_KG, u=THRUST_U, n=THRUST_N, **INERTIA))
    for bag, role, (a, b), desc in runs:
        stem, date_time = bag[:-4].split("_2016-")
        name = f"{stem}_{date_time[6:].replace('-', '')}"  # e.g. sinPhiA1F05_084712
        run = out / "cases" / "pool" / name
        run.mkdir(parents=True, exist_ok=True)
        text = RUN.format(role=role, description=desc, bag=bag_dir / bag, a=a, b=b)
        if yaw:
            text = text.replace("closed-loop attitude and rate controller", "open loop")
        (run / "run.yaml").write_text(text)
        print(f"{name:24s} {role:8s} {a:6.3f}-{b:6.3f} s of {bag}")


if __name__ == "__main__":
    modes = [a for a in sys.argv[1:] if a.startswith("--")]
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    if len(args) != 2 or len(modes) > 1 or not set(modes) <= {"--open-loop-yaw", "--unseen"}:
        sys.exit(__doc__)
    main(args[0], args[1], modes[0] if modes else None)
