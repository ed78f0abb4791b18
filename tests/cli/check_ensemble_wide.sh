#!/usr/bin/env bash
# check_ensemble_wide.sh WORK SCENE FABRICA MPIEXEC: the grouping of ranks on 8 and 16 ranks
# (oversubscribed), docs/triaxial.md "Realisations".
#   1. SCENE with four realisations (seeds 3-6), groups = 4, on 8 ranks: four groups of 2 ranks;
#   2. the same on 16 ranks: four groups of 4 ranks;
#   3. seeds = [5] alone on 1 rank;
#   4. every CSV file of each realisation equal between 1 and 2 (summary.csv but the wall-clock
#      seconds; a run's results do not depend on its group's rank count), seed 5's equal to 3's,
#      and the peak memory per rank of each printed (a group of 4 ranks holds at most what a
#      group of 2 does, within 25 %: nothing is held per ensemble rank).
set -eu
work=$1 scene=$2 fabrica=$3 mpiexec=$4
rm -rf "$work"; mkdir -p "$work"
sed 's/^realisations = 2.*/realisations = 4/; s/^groups = .*/groups = 4/' "$scene" > "$work/four.toml"
for n in 8 16; do
  "$mpiexec" --oversubscribe -np $n "$fabrica" run "$work/four.toml" -o "$work/np$n" > "$work/np$n.log" 2>&1 \
    || { cat "$work/np$n.log"; exit 1; }
  grep -q "4 run(s) (seeds 3 4 5 6) in 4 group(s) of $((n / 4)) rank(s)" "$work/np$n.log" \
    || { echo "not four groups of $((n / 4)) ranks"; cat "$work/np$n.log"; exit 1; }
done
sed 's/^realisations = 2.*/seeds = [5]/' "$scene" > "$work/alone.toml"
"$fabrica" run "$work/alone.toml" -o "$work/alone" > "$work/alone.log" 2>&1 || { cat "$work/alone.log"; exit 1; }
same() {  # two output directories' CSV files
  local a=$1 b=$2 f n=0
  for f in $(cd "$a" && find . -name '*.csv' | sort); do
    if [ "$(basename "$f")" = summary.csv ]; then
      cmp -s <(rev "$a/$f" | cut -d, -f2- | rev) <(rev "$b/$f" | cut -d, -f2- | rev) || { echo "DIFFERS: $a/$f $b/$f"; return 1; }
    else
      cmp -s "$a/$f" "$b/$f" || { echo "DIFFERS: $a/$f $b/$f"; return 1; }
    fi
    n=$((n + 1))
  done
  [ "$n" -ge 5 ] || { echo "only $n CSV files in $a"; return 1; }
  echo "same: $n CSV files of $a and $b"
}
for s in 3 4 5 6; do same "$work/np8/seed_$s" "$work/np16/seed_$s"; done
same "$work/np16/seed_5" "$work/alone"
[ "$(tail -n +2 "$work/np16/summary.csv" | cut -d, -f1 | tr '\n' ' ')" = "3 3 4 4 5 5 6 6 " ] \
  || { echo "summary rows"; cat "$work/np16/summary.csv"; exit 1; }
# The peak memory per rank: "peak memory per rank: X MB at most ..." of each group's last run.
m8=$(grep -o "peak memory per rank: [0-9.]* MB at most" "$work/np8.log" | awk '{print $5}' | sort -g | tail -1)
m16=$(grep -o "peak memory per rank: [0-9.]* MB at most" "$work/np16.log" | awk '{print $5}' | sort -g | tail -1)
echo "peak memory per rank: $m8 MB at most on 8 ranks (groups of 2), $m16 MB on 16 ranks (groups of 4)"
awk -v a="$m8" -v b="$m16" 'BEGIN { exit !(a > 0 && b > 0 && b <= 1.25 * a) }' \
  || { echo "memory per rank grows with the ranks of a group"; exit 1; }
echo "ensemble on 8 and 16 ranks: ok"
