#!/usr/bin/env bash
# Time to solution of an ensemble on 2 ranks (issue 44 item 2): the same realisations run one
# after the other on both ranks ([parallel] groups = 1) and side by side, one rank each
# (groups = 2), alternating in one sitting, REPS repeats of each; prints each wall time (the whole
# mpirun, output included), the medians and their ratio.
#   REPS=3 REALISATIONS=2 CASES="[0.1]" AXIAL=0.05 benchmarks/run-ensemble.sh [build-dir]
# The scene is examples/paper_ensemble.toml (13,584 spheres, the paper protocol) with its
# realisations, mu_r cases and final axial strain set from the environment and no extra
# consolidation frictions; AXIAL=0.25 CASES="[0.0, 0.01, 0.05, 0.1, 0.15, 0.2]" is the study's sweep.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
REPS=${REPS:-3}
REALISATIONS=${REALISATIONS:-2}
CASES=${CASES:-[0.1]}
AXIAL=${AXIAL:-0.05}
bin=$build/apps/fabrica
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for g in 1 2; do
  sed -E -e "s/^realisations = .*/realisations = $REALISATIONS/" \
    -e "s/^consolidation_friction_cases = .*//" \
    -e "s/^rolling_friction_cases = .*/rolling_friction_cases = $CASES/" \
    -e "s/^axial_strain = .*/axial_strain = $AXIAL/" \
    -e "s/^groups = .*/groups = $g/" examples/paper_ensemble.toml >"$work/groups$g.toml"
done
declare -A res
for rep in $(seq 1 "$REPS"); do
  for g in 1 2; do
    t0=$(date +%s.%N)
    mpirun -np 2 "$bin" run "$work/groups$g.toml" -o "$work/out$g" --overwrite >"$work/log$g" 2>&1 ||
      { cat "$work/log$g"; exit 1; }
    t1=$(date +%s.%N)
    s=$(awk -v a="$t0" -v b="$t1" 'BEGIN {printf "%.1f", b - a}')
    echo "round $rep, groups = $g: $s s"
    res[$g]="${res[$g]:-} $s"
  done
  # The two ways must give the same results (each case bit for bit that of running it alone):
  # summary.csv the same but for its last column, the wall time.
  strip() { awk -F, 'BEGIN {OFS = ","} {NF--; print}' "$1"; }
  if ! diff <(strip "$work/out1/summary.csv") <(strip "$work/out2/summary.csv") >/dev/null; then
    echo "summary.csv differs between groups = 1 and groups = 2" >&2
    exit 1
  fi
done
med() { tr ' ' '\n' <<<"$1" | grep -v '^$' | sort -g | awk '{a[NR]=$1} END {print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'; }
m1=$(med "${res[1]}")
m2=$(med "${res[2]}")
echo
echo "$REALISATIONS realisation(s), cases $CASES to eps_1 = $AXIAL, median over $REPS: groups = 1 $m1 s," \
  "groups = 2 $m2 s: $(awk -v a="$m1" -v b="$m2" 'BEGIN {printf "%.2f", a / b}') times faster side by side"
