#!/usr/bin/env bash
# memory_falls.sh MPIEXEC FABRICA SCENE OUTDIR: runs SCENE on 1, 2, 4 and 8 ranks and checks, from
# each run's "peak memory per rank" lines (the largest rank), that the per-rank peak falls with
# the rank count:
#  - the peak RSS (VmHWM): at most 0.8 of the 1-rank peak on 2 ranks and 0.65 on 4 (an ideal
#    split gives 0.5 and 0.25 of the specimen's share plus a fixed 20-25 MB of MPI and libraries
#    per rank);
#  - the private peak (VmHWM less the shared libraries' and mapped files' pages, about 5 MB for
#    a rank with no particles): at most 0.7 / 0.5 / 0.4 of the 1-rank one on 2 / 4 / 8 ranks
#    (measured 0.59 / 0.38 / 0.28; a rank holding the whole specimen would be at 1).
# The margins are generous: the runs are oversubscribed on small machines.
set -euo pipefail
mpiexec=$1 fabrica=$2 scene=$3 out=$4
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
declare -A peak private
for n in 1 2 4 8; do
  log=$("$mpiexec" --oversubscribe -np $n "$fabrica" run "$scene" -o "$out/np$n" --overwrite)
  line=$(grep '^peak memory per rank:' <<<"$log")
  peak[$n]=$(sed -E 's/^peak memory per rank: ([0-9.]+) MB.*/\1/' <<<"$line")
  pline=$(grep '^private peak memory per rank' <<<"$log")
  private[$n]=$(sed -E 's/^private peak memory per rank \(less [0-9.]+ MB[^)]*\): ([0-9.]+) MB.*/\1/' <<<"$pline")
  echo "$n rank(s): $line"
  echo "$n rank(s): $pline"
  grep -q "300000 spheres" <<<"$log" || { echo "not the 300,000-sphere scene"; exit 1; }
done
/usr/bin/python3 - "${peak[1]}" "${peak[2]}" "${peak[4]}" "${private[1]}" "${private[2]}" "${private[4]}" "${private[8]}" <<'PY'
import sys
p1, p2, p4, q1, q2, q4, q8 = map(float, sys.argv[1:])
print(f"peak per rank: {p1:.1f} / {p2:.1f} / {p4:.1f} MB on 1 / 2 / 4 ranks; ratios {p2/p1:.2f}, {p4/p1:.2f}")
print(f"private peak per rank: {q1:.1f} / {q2:.1f} / {q4:.1f} / {q8:.1f} MB on 1 / 2 / 4 / 8 ranks; "
      f"ratios {q2/q1:.2f}, {q4/q1:.2f}, {q8/q1:.2f}")
ok = p1 > 80 and p2 <= 0.8 * p1 and p4 <= 0.65 * p1
ok = ok and q1 > 60 and q2 <= 0.7 * q1 and q4 <= 0.5 * q1 and q8 <= 0.4 * q1
sys.exit(0 if ok else 1)
PY
