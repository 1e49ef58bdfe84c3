#!/usr/bin/env python3
"""Prints the coefficients hydrofit identified on the simulated BlueROV2 beside the
simulator's, as the source repository states them (`hydro_coff_true` in its
`2d_horizontal.py` and `pso.py`: X_udot, Y_vdot, N_rdot, X_u, X_u|u|, Y_v, Y_v|v|, N_r,
N_r|r|; heave and the yaw inertia are not stated there).

    python3 scripts/bluerov2_sim/compare.py OUT
"""

import json
import sys
from pathlib import Path

SIMULATOR = {
    "X_udot": -1.7182, "Y_vdot": 0.0, "N_rdot": -0.4006,
    "X_u": -11.7391, "X_uu": 0.0, "Y_v": -20.0, "Y_vv": 0.0, "N_r": -5.0, "N_rr": 0.0,
}


def compare(out, simulator):
    """Prints the default fit's coefficients of the project `out` beside `simulator`'s."""
    params = json.loads((out / "reports" / "parameters.json").read_text())["parameters"]
    print(f"{'':8s} {'simulator':>10s} {'hydrofit':>10s} {'std err':>8s}  identifiable")
    for p in params:
        if p["model"] != "fit" or p["name"] not in simulator:
            continue
        se = p.get("stderr") or 0.0
        print(f"{p['name']:8s} {simulator[p['name']]:10.4f} {p['value']:10.4f} {se:8.4f}  {p.get('identifiable')}")


def main():
    compare(Path(sys.argv[1]), SIMULATOR)


if __name__ == "__main__":
    main()
