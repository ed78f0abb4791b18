#!/bin/bash
# stale_semaphore.sh OUT SCENE CMD...: a job killed inside MPI_File_open can leave Open MPI's
# named semaphore /dev/shm/sem.OMPIO_<file name> at 0, machine-wide. This test plants such a
# semaphore (a glibc sem_t of value 0 is 32 zero bytes) for the checkpoint file's name, then runs
# CMD run SCENE -o OUT (a run that writes checkpoints) under a 60 s limit (times
# FABRICA_TEST_TIME_FACTOR where the sanitizer build sets it): it must end with exit
# 0 and a checkpoint. Before MpiContext excluded the "sm" sharedfp component this run waited on
# the semaphore for ever (found in CI, where the kill-and-restart tests leave it behind).
set -u
out=$1; scene=$2; shift 2
sem=/dev/shm/sem.OMPIO_checkpoint.ckpt.tmp
if [ ! -d /dev/shm ] || [ ! -w /dev/shm ]; then echo "no writable /dev/shm: nothing to test"; exit 1; fi
planted=0
if [ ! -e "$sem" ]; then head -c 32 /dev/zero > "$sem" && planted=1; fi
trap '[ $planted = 1 ] && rm -f "$sem"' EXIT
rm -rf "$out"
limit=$((60 * ${FABRICA_TEST_TIME_FACTOR:-1}))
timeout -k 5 "$limit" "$@" run "$scene" -o "$out" > "$out.log" 2>&1
rc=$?
if [ $rc = 124 ] || [ $rc = 137 ]; then echo "FAIL: no exit within $limit s with a stale semaphore $sem (a hang)"; tail -3 "$out.log"; exit 1; fi
if [ $rc != 0 ]; then echo "FAIL: exit $rc"; tail -5 "$out.log"; exit 1; fi
if [ ! -s "$out/checkpoint.ckpt" ]; then echo "FAIL: no $out/checkpoint.ckpt"; exit 1; fi
echo "ok: exit 0 and a checkpoint with a stale semaphore of value 0 at $sem"
