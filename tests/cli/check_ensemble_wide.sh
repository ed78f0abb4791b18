#!/usr/bin/env bash
# check_ensemble_wide.sh WORK SCENE FABRICA MPIEXEC: the grouping of ranks on 8 and 16 ranks
# (oversubscribed), docs/triaxial.md "Realisations".
#   1. SCENE with four realisations (seeds 3-6), groups = 4, on 8 ranks: four groups of 2 ranks;
#   2. eight realisations (seeds 3-10), groups = 8, on 16 ranks: eight groups of 2 ranks;
#   3. seeds = [5] alone on 2 ranks;
#   4. every CSV file of seeds 3-6 equal between 1 and 2 and seed 5's equal to 3's (summary.csv
#      but the wall-clock seconds), and the peak memory per rank of each printed (16 ranks hold
#      at most what 8 do, within 25 %: nothing is held per rank of the whole ensemble).
# Groups of one size throughout: the trajectories are the same bits on any rank count, but the
# series' energy_error (a difference of sums of the order of the energies) differs in its 10th
# digit between 2 and 4 ranks, so runs of different group sizes are not compared here (that
# the grouping changes nothing is cli.ensemble.groups_equal_alone's, on 1 and 2 ranks).
set -eu
work=$1 scene=$2 fabrica=$3 mpiexec=$4
rm -rf "$work"; mkdir -p "$work"
sed 's/^realisations = 2.*/realisations = 4/; s/^groups = .*/groups = 4/' "$scene" > "$work/np8.toml"
sed 's/^realisations = 2.*/realisations = 8/; s/^groups = .*/groups = 8/' "$scene" > "$work/np16.toml"
for n in 8 16; do
  "$mpiexec" --oversubscribe -np $n "$fabrica" run "$work/np$n.toml" -o "$work/np$n" > "$work/np$n.log" 2>&1 \
    || { cat "$work/np$n.log"; exit 1; }
  seeds=$(seq -s ' ' 3 $((2 + n / 2)))
  grep -q "$((n / 2)) run(s) (seeds $seeds) in $((n / 2)) group(s) of 2 rank(s)" "$work/np$n.log" \
    || { echo "not $((n / 2)) groups of 2 ranks"; cat "$work/np$n.log"; exit 1; }
done
sed 's/^realisations = 2.*/seeds = [5]/' "$scene" > "$work/alone.toml"
"$mpiexec" --oversubscribe -np 2 "$fabrica" run "$work/alone.toml" -o "$work/alone" > "$work/alone.log" 2>&1 || { cat "$work/alone.log"; exit 1; }
. "$(dirname "$0")/same_csv.sh"  # same A B: the CSV files of two output directories
for s in 3 4 5 6; do same "$work/np8/seed_$s" "$work/np16/seed_$s"; done
same "$work/np16/seed_5" "$work/alone"
[ "$(tail -n +2 "$work/np16/summary.csv" | cut -d, -f1 | tr '\n' ' ')" = "3 3 4 4 5 5 6 6 7 7 8 8 9 9 10 10 " ] \
  || { echo "summary rows"; cat "$work/np16/summary.csv"; exit 1; }
# The peak memory per rank: "peak memory per rank: X MB at most ..." of each group's last run.
m8=$(grep -o "peak memory per rank: [0-9.]* MB at most" "$work/np8.log" | awk '{print $5}' | sort -g | tail -1)
m16=$(grep -o "peak memory per rank: [0-9.]* MB at most" "$work/np16.log" | awk '{print $5}' | sort -g | tail -1)
echo "peak memory per rank: $m8 MB at most on 8 ranks, $m16 MB on 16 ranks (groups of 2)"
awk -v a="$m8" -v b="$m16" 'BEGIN { exit !(a > 0 && b > 0 && b <= 1.25 * a) }' \
  || { echo "memory per rank grows with the ensemble"; exit 1; }
echo "ensemble on 8 and 16 ranks: ok"
