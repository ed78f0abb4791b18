#!/usr/bin/env bash
# kill_during_output.sh FABRICA SCENE OUT SECONDS [NP]: starts a run that writes a snapshot every
# 50 steps, kills it with SIGKILL after SECONDS, then requires that `fabrica info` reads the file
# and lists at least one snapshot. With NP > 1 the run is started under mpirun on NP ranks and
# the whole job is killed.
set -u
fabrica=$1 scene=$2 out=$3 secs=$4 np=${5:-1}
rm -rf "$out"
if [ "$np" -gt 1 ]; then
  mpirun --oversubscribe -np "$np" "$fabrica" run "$scene" -o "$out" >/dev/null 2>&1 &
else
  "$fabrica" run "$scene" -o "$out" >/dev/null 2>&1 &
fi
pid=$!
sleep "$secs"
if ! kill -0 $pid 2>/dev/null; then echo "the run ended before it was killed"; exit 1; fi
if [ "$np" -gt 1 ]; then pkill -KILL -P $pid; fi   # the ranks (children of this mpirun only)
kill -KILL $pid
wait $pid 2>/dev/null
info=$("$fabrica" info "$out/run.h5" 2>&1); rc=$?
if [ $rc -ne 0 ]; then echo "after SIGKILL: fabrica info failed (exit $rc): $info"; exit 1; fi
n=$(grep -cE '^  (consolidation|mur_)[^ ]* +[0-9]+ +[0-9.e+-]+ +[0-9]+ +[0-9]+$' <<<"$info")
echo "after SIGKILL at ${secs} s: fabrica info lists $n snapshot(s)"
[ "$n" -ge 1 ]
