#!/usr/bin/env bash
# Every figure docs/benchmarks.md quotes about time and speed, measured on this machine and
# printed in its form (its "Measured figures" section), with the machine and the date.
#   bash bench/readme.sh           # ~12 min: test run, cold and no-op build, diagnosis, benchmarks
#   FULL=1 bash bench/readme.sh    # also the first build and first test run from an empty
#                                  # target folder (~35 min more on 2 cores)
#   bash bench/readme.sh --write   # and put the section into docs/benchmarks.md (figures not measured
#                                  # this time are kept from it, with the date they were)
#   SKIP_PYTHON=1 ...              # leave out the numpy/pyswarms comparison (needs PyPI once)
set -euo pipefail
cd "$(dirname "$0")/.."
write=0
[ "${1:-}" = "--write" ] && write=1
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
say() { echo "readme.sh: $*" >&2; }
secs() { python3 -c "import sys; s=float(sys.argv[1]); print(f'{int(s//60)} min {s%60:.0f} s' if s >= 60 else f'{s:.1f} s')" "$1"; }
timed() { # timed NAME CMD...: runs CMD, stores its wall time in $out/NAME
  local t0 t1
  t0=$(date +%s.%N)
  "${@:2}" >"$out/$1.log" 2>&1 || { say "$1 failed:"; tail -20 "$out/$1.log" >&2; exit 1; }
  t1=$(date +%s.%N)
  python3 -c "print($t1 - $t0)" >"$out/$1"
}
today=$(date -u +%F)
cpu=$(lscpu | sed -n 's/^Model name:[[:space:]]*//p' | head -1)
simd=$(grep -qw avx512f /proc/cpuinfo && echo AVX-512 || (grep -qw avx2 /proc/cpuinfo && echo AVX2 || echo "no AVX2"))
cores=$(nproc)

rows="$out/rows"
: >"$rows"
row() { printf '| %s | %s |\n' "$1" "$2" >>"$rows"; }
kept() { # the current row of docs/benchmarks.md starting with $1, if any
  sed -n '/<!-- measured:begin/,/<!-- measured:end/p' docs/benchmarks.md | grep -F "| $1 |" | head -1 || true
}

if [ "${FULL:-0}" = 1 ]; then
  cold="$(mktemp -d)"
  say "first build from an empty target folder (polars: many minutes)"
  CARGO_TARGET_DIR="$cold" timed first_build cargo build --release --locked
  say "first test run after it"
  CARGO_TARGET_DIR="$cold" timed first_test cargo test --release --locked
  rm -rf "$cold"
  row "first build: \`cargo build --release --locked\` on a fresh clone" "$(secs "$(cat "$out/first_build")") ($today)"
  row "first test run after it: \`cargo test --release --locked\` (builds the tests, then runs them)" "$(secs "$(cat "$out/first_test")") ($today)"
else
  for k in "first build: \`cargo build --release --locked\` on a fresh clone" \
    "first test run after it: \`cargo test --release --locked\` (builds the tests, then runs them)"; do
    line=$(kept "$k")
    if [ -n "$line" ]; then echo "$line" >>"$rows"; else row "$k" "not measured (FULL=1 bash bench/readme.sh)"; fi
  done
fi

say "compiling (warm)"
cargo build --release --locked --all-targets --quiet
bin="$(realpath "${CARGO_TARGET_DIR:-target}/release/hydrofit")"
say "test run with everything compiled"
timed tests cargo test --release --locked
row "test run with everything compiled: \`cargo test --release --locked\`" "$(secs "$(cat "$out/tests")")"

if ! command -v hyperfine >/dev/null 2>&1; then
  say "installing hyperfine (Debian)"
  if [ "$(id -u)" = 0 ]; then apt-get install -y -qq hyperfine >/dev/null; else sudo apt-get install -y -qq hyperfine >/dev/null; fi
fi
work="$out/project"
mkdir -p "$work/reports"
cp -r Cargo.toml pipeline.yaml cases "$work"/
say "cold and no-op builds of the shipped project"
hyperfine --warmup 1 --runs "${COLD_RUNS:-5}" --export-json "$out/cold.json" \
  --prepare "$bin --project $work clean >/dev/null" "$bin --project $work build" >/dev/null
"$bin" --project "$work" build 2>/dev/null
hyperfine --warmup 3 --runs "${NOOP_RUNS:-50}" -N --export-json "$out/noop.json" "$bin --project $work build" >/dev/null
"$bin" --project "$work" clean >/dev/null
"$bin" --project "$work" build >"$out/build.log" 2>&1
mean() { python3 -c "import json,sys; r=json.load(open(sys.argv[1]))['results'][0]; f=float(sys.argv[2]); print(f\"{r['mean']*f:.{sys.argv[3]}f} {sys.argv[4]} ± {r['stddev']*f:.{sys.argv[3]}f} ({len(r['times'])} runs)\")" "$@"; }
instances=$("$bin" --project "$work" graph | wc -l)
diag=$(python3 -c "import json; print(f\"{json.load(open('$work/reports/diagnosis.json'))['elapsed_s']:.1f} s\")")
row "cold \`hydrofit build\` of the shipped project, $instances stage instances (cache removed before each run)" "$(mean "$out/cold.json" 1 2 s)"
row "its diagnosis stage (six 120 s pool runs)" "$diag"
row "no-op \`hydrofit build\` (everything cached)" "$(mean "$out/noop.json" 1000 1 ms)"

say "benchmarks"
"$bin" bench --objective diagnosis >"$out/diag.txt"
d=$(sed -n 's/^  \([0-9.]*\) s (target.*/\1/p' "$out/diag.txt")
row "diagnosis over 16 one-minute field-twin runs (\`hydrofit bench --objective diagnosis\`; target under 10 s)" "$d s"
"$bin" bench --objective pem >"$out/pem.txt"
d=$(sed -n 's/^  \([0-9.]*\) s (target.*/\1/p' "$out/pem.txt")
row "default pool fit (prediction-error method) on 16 one-minute field-twin runs (\`hydrofit bench --objective pem\`; target under 10 s)" "$d s"
pick() { sed -n "$2" "$1" | head -1; }
# "58653090 evaluations/s (19.7 GFLOP/s)" with thousands separated
alone() { python3 -c "import sys; n, g = sys.argv[1].split(); print(f'{int(n):,} evaluations/s ({g} GFLOP/s)')" "$(pick "$1" 's/.*objective alone: \([0-9]*\) evaluations\/s = \([0-9.]*\) GFLOP.*/\1 \2/p')"; }
for spec in "l2 300" "l1 100"; do
  set -- $spec
  "$bin" bench --norm "$1" --population 40 --iterations "$2" --export "$out/$1.bin" >"$out/$1.txt"
  rate=$(alone "$out/$1.txt")
  bound=$(pick "$out/$1.txt" 's/.*(\([0-9.]*x\) from the bound).*/\1/p')
  peak=$(pick "$out/$1.txt" 's/.*FMA peak on [0-9]* threads): \([0-9.]*\) GFLOP.*/\1/p')
  row "$(echo "$1" | tr a-z A-Z) equation-error objective, seed-001 size (\`hydrofit bench --norm $1\`)" "$rate, $bound from the measured FMA peak ($peak GFLOP/s)"
done
"$bin" bench --objective output --population 40 --iterations 300 --export "$out/oe.bin" >"$out/oe.txt"
ms=$(pick "$out/oe.txt" 's/.*evaluations\/s (\([0-9.]*\) ms each).*/\1/p')
rate=$(alone "$out/oe.txt")
bound=$(pick "$out/oe.txt" 's/.*(\([0-9.]*x\) from the bound).*/\1/p')
peak=$(pick "$out/oe.txt" 's/.*FMA peak on [0-9]* threads): \([0-9.]*\) GFLOP.*/\1/p')
row "output-error objective: the 33 twin CFD cases simulated (\`hydrofit bench --objective output\`; target within 4x of the bound)" "$ms ms per evaluation in QPSO; alone $rate, $bound from the measured FMA peak ($peak GFLOP/s)"
"$bin" bench --objective six-dof >"$out/six.txt"
size=$(pick "$out/six.txt" 's/.*(CUSTOM): \([0-9]*\) rows x \([0-9]*\) terms.*/\1 rows x \2 terms/p')
ols=$(pick "$out/six.txt" 's/.*ols solve.*(build + solve \([0-9.]*\) ms).*/\1/p')
tls=$(pick "$out/six.txt" 's/.*tls solve.*(build + solve \([0-9.]*\) ms).*/\1/p')
cstep=$(pick "$out/six.txt" 's/.*coupled (CUSTOM truth) *\([0-9]*\) ns.*/\1/p')
dstep=$(pick "$out/six.txt" 's/.*simulation, diagonal *\([0-9]*\) ns.*/\1/p')
clane=$(pick "$out/six.txt" 's/.*coupled, 8 per SIMD lane *\([0-9.]*\) ns per RK4 step per candidate (\([0-9.]*\) GFLOP.*/\1 ns (\2 GFLOP\/s)/p')
dlane=$(pick "$out/six.txt" 's/.*diagonal, 8 per SIMD lane *\([0-9.]*\) ns.*/\1 ns/p')
row "seed 003's CUSTOM regression, $size, built and solved (\`hydrofit bench --objective six-dof\`; target well under 1 s)" "OLS $ols ms, TLS $tls ms"
row "one RK4 step of a six-DOF model (same bench)" "scalar: coupled (241 terms) $cstep ns, diagonal $dstep ns; eight candidates per SIMD pass, per candidate: coupled $clane, diagonal $dlane"

if [ "${SKIP_PYTHON:-0}" != 1 ]; then
  venv="${HYDROFIT_BENCH_VENV:-$HOME/.cache/hydrofit-bench-venv}"
  if [ ! -x "$venv/bin/python" ]; then
    say "installing numpy and pyswarms into $venv"
    python3 -m venv "$venv"
    "$venv/bin/pip" install --quiet numpy pyswarms
  fi
  ratio() { python3 -c "import sys; print(f'{float(sys.argv[1]) / float(sys.argv[2]):,.0f}x')" "$1" "$2"; }
  own() { pick "$1" 's/.* = \([0-9.]*\) evaluations\/s.*/\1/p'; }
  "$venv/bin/python" bench/qpso_compare.py "$out/l2.bin" l2 40 300 >"$out/l2py.txt"
  "$venv/bin/python" bench/qpso_compare.py "$out/l1.bin" l1 40 100 >"$out/l1py.txt"
  "$venv/bin/python" bench/qpso_output_error.py "$out/oe.bin" 40 5 >"$out/oepy.txt"
  np() { sed -n 's/^numpy qpso.* = \([0-9.]*\) evaluations\/s.*/\1/p' "$1" | head -1; }
  row "QPSO in hydrofit against the same algorithm in numpy, vectorised over the swarm (\`bash bench/qpso.sh\`)" \
    "L2 $(ratio "$(own "$out/l2.txt")" "$(np "$out/l2py.txt")"), L1 $(ratio "$(own "$out/l1.txt")" "$(np "$out/l1py.txt")"), output error $(ratio "$(own "$out/oe.txt")" "$(np "$out/oepy.txt")") faster"
fi

block="$out/block.md"
{
  echo "<!-- measured:begin: printed by bench/readme.sh; do not edit by hand -->"
  echo "Measured with \`bash bench/readme.sh\` on $today: $cpu, $cores cores ($simd)."
  echo
  echo "| what | measured |"
  echo "|---|---|"
  cat "$rows"
  echo "<!-- measured:end -->"
} >"$block"
cat "$block"
if [ "$write" = 1 ]; then
  python3 - "$block" <<'PY'
import re, sys
block = open(sys.argv[1]).read().rstrip("\n")
text = open("docs/benchmarks.md").read()
pattern = re.compile(r"<!-- measured:begin.*?<!-- measured:end -->", re.S)
if not pattern.search(text):
    sys.exit("docs/benchmarks.md has no <!-- measured:begin --> ... <!-- measured:end --> section")
open("docs/benchmarks.md", "w").write(pattern.sub(lambda _: block, text, count=1))
PY
  say "docs/benchmarks.md updated"
fi
