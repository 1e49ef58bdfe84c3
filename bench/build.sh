#!/usr/bin/env bash
# Benchmark of the build engine (not a test): a cold `hydrofit build` of the shipped project
# (cache removed before every run) and a no-op build (everything cached), each timed over
# repeated runs by hyperfine on a scratch copy of the project.
#   bash bench/build.sh            # 10 cold runs, 50 no-op runs
# Targets (issue 2): no-op < 20 ms, cold < 15 s on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v hyperfine >/dev/null 2>&1; then
  echo "installing hyperfine (Debian)..."
  if [ "$(id -u)" = 0 ]; then apt-get install -y -qq hyperfine >/dev/null; else sudo apt-get install -y -qq hyperfine >/dev/null; fi
fi
cargo build --release --locked --quiet
bin="${CARGO_TARGET_DIR:-target}/release/hydrofit"
bin="$(realpath "$bin")"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
cp -r Cargo.toml pipeline.yaml cases "$work"/
mkdir -p "$work/reports"
hyperfine --warmup 1 --runs "${COLD_RUNS:-10}" \
  --prepare "$bin --project $work clean >/dev/null" \
  -n "cold build" "$bin --project $work build"
"$bin" --project "$work" build 2>/dev/null
hyperfine --warmup 3 --runs "${NOOP_RUNS:-50}" -N \
  -n "no-op build" "$bin --project $work build"
