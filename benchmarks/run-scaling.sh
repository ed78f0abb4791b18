#!/usr/bin/env bash
# Strong and weak scaling of Fabrica on dense-13584 at 1 and 2 ranks, alternating the runs in one
# sitting, REPS repeats of each; prints the medians and the parallel efficiencies.
#   REPS=3 STEPS=2000 benchmarks/run-scaling.sh [build-dir]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
REPS=${REPS:-3}
STEPS=${STEPS:-2000}
bin=$build/benchmarks/bench_scaling
declare -A res
for rep in $(seq 1 "$REPS"); do
  for mode in strong weak; do
    for np in 1 2; do
      out=$(mpirun --oversubscribe -np "$np" "$bin" "$mode" 1 "$STEPS")
      grep -E '^(phases|RESULT)' <<<"$out"
      line=$(grep '^RESULT' <<<"$out")
      us=$(sed -E 's/.*us_per_particle_step_median=([0-9.]+).*/\1/' <<<"$line")
      echo "round $rep, $mode, $np rank(s): $us us per particle-step"
      res[$mode,$np]="${res[$mode,$np]:-} $us"
    done
  done
done
med() { tr ' ' '\n' <<<"$1" | grep -v '^$' | sort -g | awk '{a[NR]=$1} END {print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'; }
echo
echo "median us per particle-step over $REPS sitting(s), $STEPS steps:"
for mode in strong weak; do
  u1=$(med "${res[$mode,1]}"); u2=$(med "${res[$mode,2]}")
  if [ "$mode" = strong ]; then eff=$(awk -v a="$u1" -v b="$u2" 'BEGIN {printf "%.1f", 100*a/(2*b)}')
  else eff=$(awk -v a="$u1" -v b="$u2" 'BEGIN {printf "%.1f", 100*a/(2*b)}'); fi
  echo "  $mode: 1 rank $u1, 2 ranks $u2, parallel efficiency $eff %"
done
echo "(efficiency = us(1 rank) / (2 x us(2 ranks)); for weak scaling us is per particle of the"
echo " doubled specimen, so the same formula gives time(1 rank, N) / time(2 ranks, 2N))"
