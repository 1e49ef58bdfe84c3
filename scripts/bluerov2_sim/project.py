#!/usr/bin/env python3
"""Writes a hydrofit project that reads a simulated BlueROV2's tables where they are.

The tables are those of github.com/dream-oyh/LS-PSO-Hydro-coff-identification (no licence:
nothing of them is copied; give the path of a clone or of a folder with its `2d_data/` and
`3d_data/`): a Gazebo BlueROV2 flown in the horizontal plane (`2d_data`, 58 s) and in three
dimensions (`3d_data`, 115 s), each a pose table (position, orientation quaternion, world-frame
linear and angular velocity; the simulator's own state, not a sensor's) and a table of the six
thrusters' thrust in newtons, both at 20 Hz with a `timestamp` column in seconds of the
simulator's clock.

hydrofit reads such tables as a log (a folder of CSV files with a time column, a topic per
file), the thrusts through `command: newtons` and the units' positions and directions the
repository's scripts use. Each recording is cut into runs of about 29 s by `span_s`; the last
run of each is held out.

    python3 scripts/bluerov2_sim/project.py SRC OUT
    hydrofit build --project OUT
    python3 scripts/heldout.py OUT --runs
    python3 scripts/bluerov2_sim/compare.py OUT
"""

import argparse
from pathlib import Path

PIPELINE = """\
# A simulated BlueROV2 (Gazebo) of github.com/dream-oyh/LS-PSO-Hydro-coff-identification,
# read from its tables where they are (no licence: not part of hydrofit). Written by
# scripts/bluerov2_sim/project.py.
vehicle:
  name: simulated BlueROV2 (dream-oyh/LS-PSO-Hydro-coff-identification)
  # The repository's mass and yaw inertia (0.2 m (L^2 + W^2)); the added inertia is identified.
  mass_kg: 11.2
  inertia_kg_m2: {zz: 0.577}
  dofs: [surge, sway, heave, yaw]
  structure: diagonal
  constant_force: [heave]
  thrusters:
    # The tables log each thruster's thrust (N). Units as the repository's scripts place them
    # (FLU there: y and z negated here, the body frame being x forward, y starboard, z down).
    command: newtons
    units:
      - {position_m: [0.1355, 0.1, 0.0725], direction: [0.707, -0.707, 0]}
      - {position_m: [0.1355, -0.1, 0.0725], direction: [0.707, 0.707, 0]}
      - {position_m: [-0.1475, 0.1, 0.0725], direction: [-0.707, -0.707, 0]}
      - {position_m: [-0.1475, -0.1, 0.0725], direction: [-0.707, 0.707, 0]}
      - {position_m: [0.0025, 0.1105, 0.005], direction: [0, 0, -1]}
      - {position_m: [0.0025, -0.1105, 0.005], direction: [0, 0, -1]}
stages:
  pool: {kind: pool, inputs: ["cases/pool/*/"]}
  fit: {kind: fit, from: [pool]}
  fit_ols:
    kind: fit
    from: [pool]
    settings: {method: ols}
  validate: {kind: validate, from: [fit, fit_ols, pool]}
  diagnose: {kind: diagnose, from: [fit, pool]}
  report: {kind: report, from: [fit, fit_ols, pool, validate, diagnose]}
"""

RUN = """\
role: {role}
description: "simulated BlueROV2, {what}, seconds {a}-{b} of the recording"
log:
  file: {folder}
  span_s: [{a}, {b}]
  command: {{topic: {thrust}, fields: [{thrusters}]}}
  # World-frame (ENU) velocity of an FLU body, turned into the body frame with the attitude.
  velocity: {{topic: {pose}, fields: [linear_velocity_x, linear_velocity_y, linear_velocity_z], frame: enu}}
  attitude: {{topic: {pose}, fields: [orientation_x, orientation_y, orientation_z, orientation_w]}}
  # The world-frame angular velocity: within 1.5 deg of level, the body's rates.
  rates: {{topic: {pose}, fields: [angular_velocity_x, angular_velocity_y, angular_velocity_z], frame: flu}}
  depth: {{topic: {pose}, fields: [position_z], unit: up_m}}
"""

# (folder, pose table, thrust table, thrust columns, what, spans); the last span is held out.
RECORDINGS = [
    ("3d_data", "pose_data_3d", "thrust_data_3d", [f"thrust{k}" for k in range(6)],
     "three-dimensional motion", [(0, 29), (29, 58), (58, 87), (87, 115.3)]),
    ("2d_data", "pose_data", "thrust_data", [f"thruster_{k}" for k in range(6)],
     "horizontal motion", [(0, 29), (29, 57.7)]),
]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("src", type=Path, help="a clone of dream-oyh/LS-PSO-Hydro-coff-identification")
    ap.add_argument("out", type=Path, help="the project folder to write")
    args = ap.parse_args()
    src = args.src.resolve()
    for folder, *_ in RECORDINGS:
        if not (src / folder).is_dir():
            raise SystemExit(f"{src / folder}: not found (give the repository's folder)")
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "pipeline.yaml").write_text(PIPELINE)
    for folder, pose, thrust, cols, what, spans in RECORDINGS:
        for k, (a, b) in enumerate(spans):
            run = args.out / "cases" / "pool" / f"{folder.split('_')[0]}_{chr(ord('a') + k)}"
            run.mkdir(parents=True, exist_ok=True)
            role = "validate" if k == len(spans) - 1 else "train"
            (run / "run.yaml").write_text(RUN.format(
                role=role, what=what, a=a, b=b, folder=src / folder, pose=pose, thrust=thrust,
                thrusters=", ".join(cols)))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
