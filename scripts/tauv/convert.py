#!/usr/bin/env python3
"""Writes a hydrofit project from the Tartan AUV team's pool runs of 1 December 2022.

The runs are in the public repository `Tartan-AUV/TAUV-Playground`, folder
`model-identification/data/bags-12-01-22/`: for each of 16 one-minute runs a
`wrench_<i>.csv` (the controller's commanded body wrench) and a `navigation_state_<i>.csv`
(the navigation filter's state: position, body velocity, Euler angles), both written by
`rostopic echo -p`. The repository has no licence: the files are read from the path given and
never copied into hydrofit's repository; the project written holds converted copies in the
output folder only.

    python3 scripts/tauv/convert.py /path/to/bags-12-01-22 /tmp/tauv [--fold K]

`--fold K` (0-3) holds out runs K, K+4, K+8, K+12 (default 3: runs 3, 7, 11, 15); the other 12
train. `--direct` writes run folders whose `run.yaml` reads the two topic files of each run
where they are (hydrofit reads `rostopic echo -p` files as a log; nothing is copied or
converted). `--receive-time` times the navigation log by when it was recorded rather than by its
header stamps (about 0.2 s later). Standard library only.
"""

import argparse
import csv
import math
from pathlib import Path

RUNS = range(16)

PIPELINE = """\
# A 30 kg AUV of the Tartan AUV team flown in a pool by its closed-loop controller: the
# commanded body wrench (logged by receive time, ~50 Hz, in bursts) and the navigation filter's
# body velocity, attitude and depth (header stamps, 7-20 Hz, irregular; no rates logged).
# Written by scripts/tauv/convert.py from the public runs of TAUV-Playground (no licence: not
# part of hydrofit).
vehicle:
  name: Tartan AUV (TAUV-Playground runs of 2022-12-01)
  mass_kg: 30.0
  # Not published for these runs: a guess; the added inertia is identified.
  inertia_kg_m2: {zz: 1.0}
  dofs: [surge, sway, heave, yaw]
  structure: diagonal
  # The controller holds depth against a net buoyancy it feeds forward (Z ~ 8 N).
  constant_force: [heave]
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
    settings: {method: ols}
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


def rows(path):
    with open(path, newline="") as f:
        r = csv.reader(f)
        head = next(r)
        return head, [row for row in r if row]


def col(head, name):
    return head.index(name)


def convert_run(src, i, out, role, stamp):
    wh, w = rows(src / f"wrench_{i}.csv")
    nh, n = rows(src / f"navigation_state_{i}.csv")
    t_recv = [int(x[0]) * 1e-9 for x in w]
    # The navigation state at its header stamp (when it was valid; ~0.2 s before it was received).
    t_nav = [int(x[col(nh, stamp)]) * 1e-9 for x in n]
    # The first messages of a recording can be stale (a state stamped seconds before the
    # recording began, delivered late): the run starts at the first command.
    t0 = t_recv[0]
    run = out / "cases" / "pool" / f"run_{i:02d}"
    run.mkdir(parents=True, exist_ok=True)
    (run / "run.yaml").write_text(
        f"role: {role}\ndescription: \"TAUV-Playground run {i} (2022-12-01), closed-loop pool run\"\n"
    )
    fx, fy, fz, tz = (col(wh, f"field.{k}") for k in ("force.x", "force.y", "force.z", "torque.z"))
    with open(run / "thrust.csv", "w") as f:
        f.write("t,X_N,Y_N,Z_N,N_Nm\n")
        for t, x in zip(t_recv, w):
            f.write(f"{t - t0:.6f},{x[fx]},{x[fy]},{x[fz]},{x[tz]}\n")
    u, v, wv = (col(nh, f"field.velocity.{k}") for k in "xyz")
    ro, pi, ya = (col(nh, f"field.orientation.{k}") for k in "xyz")
    z = col(nh, "field.position.z")
    keep = []
    last = -math.inf
    for t, x in zip(t_nav, n):
        if t >= t0 and t > last:  # a stamp repeated or out of order is the same state sent twice
            keep.append((t, x))
            last = t
    with open(run / "nav.csv", "w") as f, open(run / "depth.csv", "w") as g:
        f.write("t,u_m_s,v_m_s,w_m_s,roll_deg,pitch_deg,yaw_deg\n")
        g.write("t,depth_m\n")
        for t, x in keep:
            deg = [math.degrees(float(x[k])) for k in (ro, pi, ya)]
            f.write(f"{t - t0:.6f},{x[u]},{x[v]},{x[wv]},{deg[0]:.5f},{deg[1]:.5f},{deg[2]:.5f}\n")
            g.write(f"{t - t0:.6f},{x[z]}\n")


LOG_RUN = """\
role: {role}
description: "TAUV-Playground run {i} (2022-12-01), closed-loop pool run, read from its rostopic CSV files"
log:
  file: {src}
  # wrench_<i>: the controller's commanded body wrench (geometry_msgs/Wrench, receive times).
  wrench: {{topic: wrench_{i}, fields: [force.x, force.y, force.z, torque.z]}}
  # navigation_state_<i>: the navigation filter's body velocity, Euler angles (rad, FRD in
  # NED) and position (z down), at its header stamps.
  velocity: {{topic: navigation_state_{i}, fields: [velocity.x, velocity.y, velocity.z]}}
  attitude: {{topic: navigation_state_{i}, fields: [orientation.x, orientation.y, orientation.z]}}
  depth: {{topic: navigation_state_{i}, fields: [position.z]}}
"""


def direct_run(src, i, out, role):
    """A run folder whose run.yaml points at the run's two topic files in `src` (nothing copied)."""
    run = out / "cases" / "pool" / f"run_{i:02d}"
    run.mkdir(parents=True, exist_ok=True)
    (run / "run.yaml").write_text(LOG_RUN.format(role=role, i=i, src=src.resolve()))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("src", type=Path, help="the folder bags-12-01-22 of TAUV-Playground")
    ap.add_argument("out", type=Path, help="the project folder to write")
    ap.add_argument("--fold", type=int, default=3, choices=range(4))
    ap.add_argument(
        "--receive-time",
        action="store_true",
        help="time the navigation log by when it was recorded (%%time), not by its header stamps",
    )
    ap.add_argument(
        "--direct",
        action="store_true",
        help="write run folders that read the rostopic CSV files where they are (no copies, no conversion)",
    )
    a = ap.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    (a.out / "pipeline.yaml").write_text(PIPELINE)
    for i in RUNS:
        role = "validate" if i % 4 == a.fold else "train"
        if a.direct:
            direct_run(a.src, i, a.out, role)
        else:
            convert_run(a.src, i, a.out, role, "%time" if a.receive_time else "field.header.stamp")
    print(f"wrote {a.out} (held out: {[i for i in RUNS if i % 4 == a.fold]})")


if __name__ == "__main__":
    main()
