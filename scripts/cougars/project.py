#!/usr/bin/env python3
"""Writes a hydrofit project that reads the BYU FRoSt Lab CougUV's ROS 2 bags where they are.

usage: project.py /path/to/cougars-ros2 OUT

The bags are in GitHub `BYU-FRoSt-Lab/cougars-ros2` on branch `factor_graph_imu`
(`SO_lastbag_mcap/`, `SO_bag/`). That repository has no licence: nothing is copied, the run
folders' `run.yaml` name the bags by absolute path. Python's standard library only.
"""
import os
import sys

RUNS = [
    # folder, bag inside the clone, role, description
    ("so_last", "SO_lastbag_mcap/SO_lastbag_mcap_0.mcap", "train",
     "CougUV field run, 2 min at 1 m depth, heading and depth held by its controller"),
    ("so_bag", "SO_bag/SO_bag_0.mcap", "validate",
     "CougUV field run, 20 s, after so_last"),
]

LOG = """log:
  file: {bag}
  velocity: {{topic: /coug2/dvl/velocity, fields: [twist.twist.linear.x, twist.twist.linear.y, twist.twist.linear.z]}}
  attitude: {{topic: /coug2/modem_imu, quaternion: orientation, frame: enu}}
  depth: {{topic: /coug2/depth_data, fields: [pose.pose.position.z], unit: up_m}}
  actuators: {{topic: /coug2/controls/command, fields: ["fin[0..3]", thruster], columns: [fin_top_deg, fin_right_deg, fin_left_deg, prop_pct]}}
"""

PIPELINE = """# The BYU CougUV's own ROS 2 bags, read as they are (scripts/cougars/README.md). The mass and
# inertia are placeholders: the stages below identify from the actuators, not from forces.
vehicle:
  name: BYU CougUV (torpedo AUV, three tail fins and a thruster)
  mass_kg: 30.0
  inertia_kg_m2: {xx: 0.1, yy: 5.0, zz: 5.0}
  dofs: [surge, sway, heave, roll, pitch, yaw]

stages:
  pool:
    kind: pool
    inputs: ["cases/pool/*/"]
  # The yaw rate from the top fin (the rudder), an ARX model chosen by MDL.
  heading:
    kind: arx
    from: [pool]
    settings:
      input: fin_top
      output: r
      search: {na: [1, 4], nb: [1, 4], k: [0, 4]}
  report:
    kind: report
    from: [pool, heading]
"""


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    clone, out = (os.path.abspath(a) for a in sys.argv[1:])
    for folder, bag, role, description in RUNS:
        path = os.path.join(clone, bag)
        if not os.path.isfile(path):
            sys.exit(f"{path}: not found (check out branch factor_graph_imu of the clone)")
        run = os.path.join(out, "cases", "pool", folder)
        os.makedirs(run, exist_ok=True)
        with open(os.path.join(run, "run.yaml"), "w") as f:
            f.write(f"role: {role}\ndescription: {description}\n")
            f.write(LOG.format(bag=path))
    with open(os.path.join(out, "pipeline.yaml"), "w") as f:
        f.write(PIPELINE)
    print(f"wrote {out}: hydrofit build --project {out}")


if __name__ == "__main__":
    main()
