#!/usr/bin/env bash
# memory_falls.sh MPIEXEC FABRICA SCENE OUTDIR: runs SCENE on 1, 2 and 4 ranks and checks, from
# each run's "peak memory per rank" line (VmHWM, the largest rank), that the per-rank peak falls
# with the rank count: at most 0.8 of the 1-rank peak on 2 ranks and 0.65 on 4 (an ideal split
# gives 0.5 and 0.25 of the specimen's share plus a fixed 30-40 MB of MPI and libraries per rank;
# the margins are generous, the run is oversubscribed on small machines).
set -euo pipefail
mpiexec=$1 fabrica=$2 scene=$3 out=$4
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
declare -A peak
for n in 1 2 4; do
  log=$("$mpiexec" --oversubscribe -np $n "$fabrica" run "$scene" -o "$out/np$n" --overwrite)
  line=$(grep '^peak memory per rank:' <<<"$log")
  peak[$n]=$(sed -E 's/^peak memory per rank: ([0-9.]+) MB.*/\1/' <<<"$line")
  echo "$n rank(s): $line"
  grep -q "300000 spheres" <<<"$log" || { echo "not the 300,000-sphere scene"; exit 1; }
done
/usr/bin/python3 - "${peak[1]}" "${peak[2]}" "${peak[4]}" <<'PY'
import sys
p1, p2, p4 = map(float, sys.argv[1:])
print(f"peak per rank: {p1:.1f} / {p2:.1f} / {p4:.1f} MB on 1 / 2 / 4 ranks; ratios {p2/p1:.2f}, {p4/p1:.2f}")
ok = p1 > 80 and p2 <= 0.8 * p1 and p4 <= 0.65 * p1
sys.exit(0 if ok else 1)
PY
