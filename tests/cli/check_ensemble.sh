#!/usr/bin/env bash
# check_ensemble.sh WORK SCENE FABRICA MPIEXEC: realisations run side by side equal the runs of
# each seed alone (docs/triaxial.md "Realisations").
#   1. SCENE (two realisations, seeds 3 and 4, groups = "auto") on 2 ranks: two groups of one
#      rank, OUT/seed_3 and OUT/seed_4 at once;
#   2. the same scene on 1 rank: the realisations in turn;
#   3. the scene with seeds = [4] alone on 1 rank;
#   4. every CSV file of each realisation equal between 1 and 2 (summary.csv but the wall-clock
#      seconds), seed_4's equal to 3's, run.h5 of seed 4 equal to 3's (tests/cli/check_run_h5.py
#      same), and OUT/summary.csv the realisations' rows with their seed first.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
work=$1 scene=$2 fabrica=$3 mpiexec=$4
rm -rf "$work"; mkdir -p "$work"
"$mpiexec" --oversubscribe -np 2 "$fabrica" run "$scene" -o "$work/np2" > "$work/np2.log" 2>&1 || { cat "$work/np2.log"; exit 1; }
grep -q "2 run(s) (seeds 3 4) in 2 group(s) of 1 rank(s)" "$work/np2.log" || { echo "not two groups"; cat "$work/np2.log"; exit 1; }
"$fabrica" run "$scene" -o "$work/np1" > "$work/np1.log" 2>&1 || { cat "$work/np1.log"; exit 1; }
sed 's/^realisations = 2.*/seeds = [4]/' "$scene" > "$work/alone.toml"
"$fabrica" run "$work/alone.toml" -o "$work/alone" > "$work/alone.log" 2>&1 || { cat "$work/alone.log"; exit 1; }
. "$(dirname "$0")/same_csv.sh"  # same A B: the CSV files of two output directories
same "$work/np2/seed_3" "$work/np1/seed_3"
same "$work/np2/seed_4" "$work/np1/seed_4"
same "$work/np2/seed_4" "$work/alone"
/usr/bin/python3 "$here/check_run_h5.py" same "$work/np2/seed_4/run.h5" "$work/alone/run.h5"
# The ensemble's summary: a header with seed first, then seed 3's two cases and seed 4's.
[ "$(head -1 "$work/np2/summary.csv" | cut -d, -f1-2)" = "seed,case" ] || { echo "summary header"; exit 1; }
[ "$(tail -n +2 "$work/np2/summary.csv" | cut -d, -f1 | tr '\n' ' ')" = "3 3 4 4 " ] || { echo "summary rows"; cat "$work/np2/summary.csv"; exit 1; }
cmp -s <(tail -n +2 "$work/np2/summary.csv" | grep '^4,' | cut -d, -f2- | rev | cut -d, -f2- | rev) \
       <(tail -n +2 "$work/alone/summary.csv" | rev | cut -d, -f2- | rev) || { echo "seed 4's summary rows differ"; exit 1; }
echo "ensemble: ok"
