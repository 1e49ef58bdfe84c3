#!/usr/bin/env python3
"""Held-out NMAE per model and DOF from a hydrofit project's reports/validation.json: the mean
over the `role: validate` runs, for every model and the validation's baselines.

    python3 scripts/heldout.py /tmp/project [--runs]
"""

import json
import sys
from pathlib import Path


def means(model):
    per = {}
    for run in model["runs"]:
        if run.get("role") != "validate":
            continue
        for dof, s in run["dofs"].items():
            per.setdefault(dof, []).append(s["nmae"])
    return {d: sum(v) / len(v) for d, v in per.items()}


def main():
    root = Path(sys.argv[1])
    v = json.loads((root / "reports" / "validation.json").read_text())
    models = [(m["model"], m) for m in v.get("models", [])]
    models += [(f"baseline {b['model']}", b) for b in v.get("baselines", [])]
    for name, m in models:
        print(f"{name:32s}", "  ".join(f"{d} {x:.3f}" for d, x in means(m).items()))
        if "--runs" in sys.argv:
            for run in m["runs"]:
                if run.get("role") == "validate":
                    print("   ", run["run"], " ".join(f"{d} {s['nmae']:.3f}" for d, s in run["dofs"].items()))


if __name__ == "__main__":
    main()
