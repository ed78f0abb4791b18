#!/usr/bin/env bash
# ensemble_restart.sh WORK SCENE FABRICA MPIEXEC: an ensemble killed while it writes checkpoints
# and continued with --restart OUT ends as the uninterrupted one (docs/triaxial.md
# "Realisations").
#   1. SCENE on 2 ranks (two groups of one rank) into WORK/full;
#   2. the same into WORK/killed, killed with SIGKILL once the first group has written two
#      checkpoints; the runs keep their checkpoints and what they wrote;
#   3. fabrica run SCENE -o WORK/killed --restart WORK/killed: each run continues from its
#      checkpoint (or starts anew without one), the finished ones are kept;
#   4. every CSV file equal to the reference's (summary.csv but the wall-clock seconds), and each
#      run's run.h5 (tests/cli/check_run_h5.py same).
set -u
here=$(cd "$(dirname "$0")" && pwd)
work=$1 scene=$2 fabrica=$3 mpiexec=$4
rm -rf "$work"; mkdir -p "$work"
run() { "$mpiexec" --oversubscribe -np 2 "$fabrica" run "$scene" "$@"; }
run -o "$work/full" > "$work/full.log" 2>&1 || { echo "reference run failed"; cat "$work/full.log"; exit 1; }
run -o "$work/killed" > "$work/killed.log" 2>&1 &
pid=$!
descendants() { local c; for c in $(pgrep -P "$1"); do descendants "$c"; echo "$c"; done; }
for _ in $(seq 1 $((1200 * ${FABRICA_TEST_TIME_FACTOR:-1}))); do
  [ "$(grep -c "checkpoint at step" "$work/killed.log")" -ge 2 ] && break
  kill -0 $pid 2>/dev/null || break
  sleep 0.05
done
if kill -0 $pid 2>/dev/null; then
  pids="$(descendants $pid) $pid"
  kill -KILL $pids 2>/dev/null; wait $pid 2>/dev/null
  for p in $pids; do while kill -0 "$p" 2>/dev/null; do sleep 0.05; done; done
  echo "killed after: $(grep "checkpoint at step" "$work/killed.log" | tail -1)"
else
  echo "the ensemble ended before the kill"; exit 1
fi
ls "$work"/killed/*/checkpoint.ckpt >/dev/null 2>&1 || { echo "no checkpoint was written"; exit 1; }
run -o "$work/killed" --restart "$work/killed" > "$work/restart.log" 2>&1 || { echo "restart failed"; cat "$work/restart.log"; exit 1; }
grep -q "continued from its checkpoint" "$work/restart.log" || { echo "no run continued from a checkpoint"; cat "$work/restart.log"; exit 1; }
status=0
cd "$work/full"
n=0
for f in $(find . -name '*.csv' | sort); do
  if [ "$(basename "$f")" = summary.csv ]; then
    diff <(sed 's/,[^,]*$//' "$f") <(sed 's/,[^,]*$//' "../killed/$f") >/dev/null || { echo "DIFFERS: $f"; status=1; }
  else
    cmp -s "$f" "../killed/$f" || { echo "DIFFERS: $f"; status=1; }
  fi
  n=$((n + 1))
done
for h in $(find . -name run.h5 | sort); do
  /usr/bin/python3 "$here/check_run_h5.py" same "$h" "../killed/$h" > /dev/null || { echo "DIFFERS: $h"; status=1; }
done
echo "compared $n CSV files and $(find . -name run.h5 | wc -l) run.h5 files: $([ $status = 0 ] && echo equal || echo DIFFERENT)"
exit $status
