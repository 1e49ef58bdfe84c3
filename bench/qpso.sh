#!/usr/bin/env bash
# QPSO on a seed-001-sized problem (52,690 rows, 12 parameters): hydrofit against the same
# algorithm in numpy (vectorised over the swarm) and pyswarms' PSO, run side by side.
#   bash bench/qpso.sh            # population 40, 300 iterations (L2) and 100 (L1)
set -euo pipefail
cd "$(dirname "$0")/.."
# --all-targets: the same feature set as `cargo test`, so the test build is reused.
cargo build --release --locked --all-targets --quiet
bin="$(realpath "${CARGO_TARGET_DIR:-target}/release/hydrofit")"
venv="${HYDROFIT_BENCH_VENV:-$HOME/.cache/hydrofit-bench-venv}"
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet numpy pyswarms
fi
prob="$(mktemp)"
trap 'rm -f "$prob"' EXIT
for spec in "l2 300" "l1 100"; do
  set -- $spec
  "$bin" bench --norm "$1" --population 40 --iterations "$2" --export "$prob"
  "$venv/bin/python" bench/qpso_compare.py "$prob" "$1" 40 "$2"
  echo
done
# Output error (seed 001 eq. 9): every candidate simulated on the 33 twin CFD cases.
"$bin" bench --objective output --population 40 --iterations "${OUTPUT_ITERATIONS:-5}" --export "$prob"
"$venv/bin/python" bench/qpso_output_error.py "$prob" 40 "${OUTPUT_ITERATIONS:-5}"
