#!/usr/bin/env bash
# expect_fields_error.sh WORKDIR REGEX FIELDS FABRICA MPIEXEC: a scene (150 spheres, d_min 0.02 m,
# one stage) with the [fields] table FIELDS (its keys, one a line) is refused on 1 rank and on 2:
# each run exits non-zero, writes no run.h5, and the message matching REGEX is printed once (every
# rank meets the error and returns 1; rank 0 speaks for all, parallel/guard.hpp).
work=$1 regex=$2 fields=$(printf "%b" "$3") fabrica=$4 mpiexec=$5
rm -rf "$work"; mkdir -p "$work"
cat >"$work/scene.toml" <<SCENE
[particles]
count = 150
d_min = 0.020
d_max = 0.060
seed = 3
[run]
output_every = 100
[fields]
$fields
[[stage]]
type = "isotropic"
pressure = 100e3
end = { steps = 200 }
SCENE
for n in 1 2; do
  if [ $n -eq 1 ]; then err=$("$fabrica" run "$work/scene.toml" -o "$work/out$n" 2>&1 >/dev/null); rc=$?
  else err=$("$mpiexec" --oversubscribe -np 2 "$fabrica" run "$work/scene.toml" -o "$work/out$n" 2>&1 >/dev/null); rc=$?; fi
  [ $rc -ne 0 ] || { echo "$n rank(s): expected a non-zero exit"; exit 1; }
  count=$(grep -Ec -- "$regex" <<<"$err")
  [ "$count" -eq 1 ] || { echo "$n rank(s): $count messages matching '$regex' (expected 1):"; echo "$err"; exit 1; }
  [ ! -e "$work/out$n/run.h5" ] || { echo "$n rank(s): run.h5 was written"; exit 1; }
  echo "ok on $n rank(s) (exit $rc): $(grep -E -- "$regex" <<<"$err" | head -1)"
done
