#!/usr/bin/env bash
# Strong and weak scaling of Fabrica on dense-13584 at 1 and 2 ranks, alternating the runs in one
# sitting, REPS repeats of each; prints the medians and the parallel efficiencies.
#   REPS=3 STEPS=2000 benchmarks/run-scaling.sh [build-dir]
# CUTS="work even" runs the 2-rank cases once per Cartesian cut ([parallel] cut, alternating
# within each round) and prints the efficiency and the balance line of each; default: the
# scene's cut only.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
REPS=${REPS:-3}
STEPS=${STEPS:-2000}
CUTS=${CUTS:-scene}
MODES=${MODES:-strong weak}
scene=benchmarks/dense-13584.toml
bin=$build/benchmarks/bench_scaling
declare -A res
for rep in $(seq 1 "$REPS"); do
  for mode in $MODES; do
    for run in 1 $(for c in $CUTS; do echo "2:$c"; done); do
      np=${run%%:*}
      cut=${run#*:}
      args=("$mode" 1 "$STEPS")
      [ "$np" = 2 ] && [ "$cut" != scene ] && args+=("$scene" "$cut")
      out=$(mpirun --oversubscribe -np "$np" "$bin" "${args[@]}")
      grep -E '^(balance|phases|rank|RESULT)' <<<"$out"
      line=$(grep '^RESULT' <<<"$out")
      us=$(sed -E 's/.*us_per_particle_step_median=([0-9.]+).*/\1/' <<<"$line")
      key=$mode,$np
      [ "$np" = 2 ] && key=$mode,2,$cut
      echo "round $rep, $mode, $np rank(s)$([ "$np" = 2 ] && echo ", cut $cut"): $us us per particle-step"
      res[$key]="${res[$key]:-} $us"
    done
  done
done
med() { tr ' ' '\n' <<<"$1" | grep -v '^$' | sort -g | awk '{a[NR]=$1} END {print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'; }
echo
echo "median us per particle-step over $REPS sitting(s), $STEPS steps:"
for mode in $MODES; do
  u1=$(med "${res[$mode,1]}")
  for cut in $CUTS; do
    u2=$(med "${res[$mode,2,$cut]}")
    eff=$(awk -v a="$u1" -v b="$u2" 'BEGIN {printf "%.1f", 100*a/(2*b)}')
    echo "  $mode$([ "$cut" != scene ] && echo ", cut $cut"): 1 rank $u1, 2 ranks $u2, parallel efficiency $eff %"
  done
done
echo "(efficiency = us(1 rank) / (2 x us(2 ranks)); for weak scaling us is per particle of the"
echo " doubled specimen, so the same formula gives time(1 rank, N) / time(2 ranks, 2N))"
