#!/usr/bin/env bash
# kill_during_output.sh FABRICA SCENE OUT SECONDS [NP]: starts a run that writes a snapshot every
# 50 steps, waits until run.xmf lists 3 flushed snapshots (at most 60 s, times
# FABRICA_TEST_TIME_FACTOR where the sanitizer build sets it), lets it run SECONDS
# more and kills it with SIGKILL (with NP > 1 the job is started under mpirun on NP ranks and
# its ranks are killed too). Then `fabrica info` must read the file and list at least the 3
# snapshots.
set -u
fabrica=$1 scene=$2 out=$3 secs=$4 np=${5:-1}
rm -rf "$out"
if [ "$np" -gt 1 ]; then
  mpirun --oversubscribe -np "$np" "$fabrica" run "$scene" -o "$out" >/dev/null 2>&1 &
else
  "$fabrica" run "$scene" -o "$out" >/dev/null 2>&1 &
fi
pid=$!
for _ in $(seq 1 $((600 * ${FABRICA_TEST_TIME_FACTOR:-1}))); do
  [ "$(grep -c '<Time ' "$out/run.xmf" 2>/dev/null)" -ge 3 ] 2>/dev/null && break
  kill -0 $pid 2>/dev/null || break
  sleep 0.1
done
sleep "$secs"
if ! kill -0 $pid 2>/dev/null; then echo "the run ended (or never started) before it was killed"; exit 1; fi
if [ "$np" -gt 1 ]; then pkill -KILL -P $pid; fi   # the ranks (children of this mpirun only)
kill -KILL $pid
wait $pid 2>/dev/null
info=$("$fabrica" info "$out/run.h5" 2>&1); rc=$?
if [ $rc -ne 0 ]; then echo "after SIGKILL: fabrica info failed (exit $rc): $info"; exit 1; fi
n=$(grep -cE '^  (consolidation|mur_)[^ ]* +[0-9]+ +[0-9.e+-]+ +[0-9]+ +[0-9]+$' <<<"$info")
echo "killed ${secs} s after the 3rd snapshot: fabrica info lists $n snapshot(s)"
[ "$n" -ge 3 ]
