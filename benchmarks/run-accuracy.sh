#!/usr/bin/env bash
# Run time against error (docs/accuracy.md): builds bench_accuracy, runs the impact scenes and the
# small triaxial sweep, writes benchmarks/accuracy/*.csv and the figures docs/figures/accuracy_*.png.
#   benchmarks/run-accuracy.sh [N=500] [EPS=0.08] [EPS_SHORT=0.01]
# (about 1.5 CPU-minutes at the defaults): the sweep to EPS into benchmarks/accuracy/, and the
# same sweep over the short window EPS_SHORT (before the runs decorrelate) into .../short/.
# The machine load (uptime) is printed before and after and kept in benchmarks/accuracy/load.txt.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
build=${BUILD:-$root/build}
n=${1:-500}
eps=${2:-0.08}
eps_short=${3:-0.01}
out=$here/accuracy
mkdir -p "$out/short" "$root/docs/figures"
[ -f "$build/CMakeCache.txt" ] || cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release
cmake --build "$build" -j2 --target bench_accuracy
{ echo "date: $(date -u)"; echo "before: $(uptime)"; echo "N=$n EPS=$eps"; } > "$out/load.txt"
"$build/benchmarks/bench_accuracy" impact "$out" | tee "$out/impact.txt"
"$build/benchmarks/bench_accuracy" triaxial "$out" "$n" "$eps" | tee "$out/triaxial.txt"
echo "middle: $(uptime)" >> "$out/load.txt"
"$build/benchmarks/bench_accuracy" triaxial "$out/short" "$n" "$eps_short" | tee "$out/short/triaxial.txt"
echo "after: $(uptime)" >> "$out/load.txt"
cat "$out/load.txt"
/usr/bin/python3 "$here/plot_accuracy.py" "$out" "$root/docs/figures" | tee "$out/pareto.txt"
/usr/bin/python3 "$here/plot_accuracy.py" "$out/short" "$root/docs/figures" _short | tee "$out/short/pareto.txt"
