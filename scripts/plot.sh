#!/usr/bin/env bash
# The plotting step of a run: every figure its output directory supports.
#   bash scripts/plot.sh OUT
# - a triaxial run (OUT/summary.csv with the cases' rolling_friction): apps/plot_triaxial.py, and
#   with the fabric analysis apps/plot_fabric.py and the study's figures and report
#   (apps/plot_paper.py);
# - a run whose stages sheared the cell (OUT/series.csv with gamma_12): apps/plot_shear.py
#   (OUT/shear.png);
# - any run with OUT/series.csv: apps/plot_series.py (stress, coordination, energies).
# Uses Debian's /usr/bin/python3 (python3-numpy, python3-matplotlib, python3-h5py).
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?usage: bash scripts/plot.sh OUT}
[ -d "$out" ] || { echo "plot.sh: $out: no such output directory" >&2; exit 1; }
drew=0
if [ -f "$out/summary.csv" ] && head -1 "$out/summary.csv" | grep -q rolling_friction; then
  /usr/bin/python3 apps/plot_triaxial.py "$out"   # from OUT/run.h5 (CSV without h5py)
  if compgen -G "$out/*/fabric.csv" >/dev/null; then
    /usr/bin/python3 apps/plot_fabric.py "$out"
    /usr/bin/python3 apps/plot_paper.py "$out"   # OUT/figures/fig03..fig12, OUT/report.html
  fi
  drew=1
fi
if [ -f "$out/series.csv" ]; then
  if head -1 "$out/series.csv" | tr ',' '\n' | grep -qx gamma_12; then
    /usr/bin/python3 apps/plot_shear.py "$out"
  fi
  /usr/bin/python3 apps/plot_series.py "$out/series.csv" -o "$out"
  drew=1
fi
[ "$drew" = 1 ] || { echo "plot.sh: $out holds neither summary.csv of a triaxial run nor series.csv" >&2; exit 1; }
