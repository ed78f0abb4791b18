#!/usr/bin/env bash
# restart_after_kill.sh WORKDIR PATTERN SCENE CMD...: the checkpoint/restart acceptance test.
#   1. CMD run SCENE -o WORKDIR/full            (uninterrupted reference)
#   2. CMD run SCENE -o WORKDIR/killed, killed with SIGKILL (every process of it) as soon as
#      its output matches PATTERN (a checkpoint line); the last complete checkpoint remains
#   3. CMD run SCENE -o WORKDIR/killed --restart WORKDIR/killed/checkpoint.ckpt
#   4. every CSV file of the reference equals the restarted run's (summary.csv: every column
#      but the last, the wall-clock seconds); with RESTART_CMD, numbers to a relative 1e-8.
#   5. the restarted run continued the killed run's OUT/run.h5: it equals the reference's
#      (snapshot list and contents, series, XDMF; tests/cli/check_restart_h5.py, with
#      $PYTHON, default /usr/bin/python3; exit 77 = skipped when it lacks h5py, after the CSV
#      files compared equal).
#   6. the finished run restarted once more from (a copy of) the same checkpoint: now run.h5
#      and the CSV files hold everything after the checkpoint's step (rows, snapshots, later
#      cases), which must go; 4 and 5 again.
# CMD is the executable, optionally behind a launcher (mpiexec -np 2 .../fabrica). With
# RESTART_CMD set (e.g. "mpiexec -np 2 .../fabrica"), step 3 runs that instead: a restart on
# another rank count.
set -u
here=$(cd "$(dirname "$0")" && pwd)
work=$1 pattern=$2 scene=$3; shift 3
rm -rf "$work"; mkdir -p "$work"
"$@" run "$scene" -o "$work/full" >"$work/full.log" 2>&1 || { echo "reference run failed"; cat "$work/full.log"; exit 1; }

"$@" run "$scene" -o "$work/killed" >"$work/killed.log" 2>&1 &
pid=$!
# The processes of the run: the launcher and its descendants (Open MPI puts each rank in a
# process group of its own, so the ranks are found by parent).
descendants() { local c; for c in $(pgrep -P "$1"); do descendants "$c"; echo "$c"; done; }
# At most 60 s (times FABRICA_TEST_TIME_FACTOR, set by the sanitizer build: tests/CMakeLists.txt).
for _ in $(seq 1 $((1200 * ${FABRICA_TEST_TIME_FACTOR:-1}))); do
  grep -Eq -- "$pattern" "$work/killed.log" && break
  kill -0 $pid 2>/dev/null || break
  sleep 0.05
done
if kill -0 $pid 2>/dev/null; then
  pids="$(descendants $pid) $pid"
  kill -KILL $pids 2>/dev/null; wait $pid 2>/dev/null
  for p in $pids; do while kill -0 "$p" 2>/dev/null; do sleep 0.05; done; done
  echo "killed with SIGKILL after: $(grep -E -- "$pattern" "$work/killed.log" | tail -1)"
else
  wait $pid; echo "the run ended before the kill (still restarting from its last checkpoint)"
fi
grep -Eq -- "$pattern" "$work/killed.log" || { echo "no checkpoint matching '$pattern' was written"; cat "$work/killed.log"; exit 1; }
"$@" checkpoint-info "$work/killed/checkpoint.ckpt" || exit 1
cp "$work/killed/checkpoint.ckpt" "$work/kill-time.ckpt"
restart=("$@")
[ -n "${RESTART_CMD:-}" ] && read -r -a restart <<<"$RESTART_CMD"

# compare LABEL: the CSV files and run.h5 of WORKDIR/killed against WORKDIR/full.
h5skipped=0
compare() {
  local status=0 f
  pushd "$work/full" >/dev/null
  for f in $(find . -name '*.csv' | sort); do
    if [ "$(basename "$f")" = summary.csv ]; then
      diff <(sed 's/,[^,]*$//' "$f") <(sed 's/,[^,]*$//' "../killed/$f") >/dev/null || { echo "DIFFERS: $f"; status=1; }
    elif [ -n "${RESTART_CMD:-}" ]; then
      # Another rank count: the measures are sums over ranks in another order, equal to rounding
      # (a difference of large numbers such as energy_error shows it in the 10th digit).
      paste -d'\n' "$f" "../killed/$f" | awk -F, -v file="$f" '
        NR % 2 == 1 { split($0, a, ","); n = NF; next }
        { if (NF != n) { print "DIFFERS: " file ": row " NR / 2 " has another shape"; bad = 1; next }
          for (i = 1; i <= NF; ++i) if (a[i] != $i) {
            d = a[i] - $i; d = d < 0 ? -d : d; s = (a[i] < 0 ? -a[i] : a[i]) + ($i < 0 ? -$i : $i)
            if (a[i] + 0 != a[i] || d > 1e-8 * s + 1e-300) { print "DIFFERS: " file ": row " NR / 2 ", column " i ": " a[i] " vs " $i; bad = 1 }
            else ++rounded } }
        END { if (rounded) print "  " file ": " rounded " values equal to rounding only (relative < 1e-8)"; exit bad }' \
        || status=1
      [ "$(wc -l <"$f")" = "$(wc -l <"../killed/$f")" ] || { echo "DIFFERS: $f (row count)"; status=1; }
    else
      cmp -s "$f" "../killed/$f" || { echo "DIFFERS: $f"; diff "$f" "../killed/$f" | head -5; status=1; }
    fi
    [ $status -eq 0 ] && echo "same: $f ($(wc -l <"$f") lines)"
  done
  popd >/dev/null
  [ $status -eq 0 ] || exit $status
  if [ -e "$work/full/run.h5" ]; then
    "${PYTHON:-/usr/bin/python3}" "$here/check_restart_h5.py" "$work/full" "$work/killed" ${RESTART_CMD:+--rounding}
    case $? in
      0) ;;
      77) h5skipped=1 ;;
      *) exit 1 ;;
    esac
  fi
}

echo "== restart after the kill"
"${restart[@]}" run "$scene" -o "$work/killed" --restart "$work/killed/checkpoint.ckpt" >"$work/restart.log" 2>&1 \
  || { echo "restart failed"; cat "$work/restart.log"; exit 1; }
grep -E "restarted|resumed" "$work/restart.log"
grep "did not exist" "$work/restart.log" && { echo "the restart did not find run.h5"; exit 1; }
compare

echo "== the finished run restarted again from the checkpoint of the kill"
"${restart[@]}" run "$scene" -o "$work/killed" --restart "$work/kill-time.ckpt" >"$work/restart2.log" 2>&1 \
  || { echo "second restart failed"; cat "$work/restart2.log"; exit 1; }
grep -E "restarted|resumed" "$work/restart2.log"
compare
[ $h5skipped -eq 0 ] || { echo "run.h5 not compared: skipped (exit 77)"; exit 77; }
exit 0
