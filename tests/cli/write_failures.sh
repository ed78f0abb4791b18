#!/usr/bin/env bash
# write_failures.sh KIND WORKDIR SCENE CMD...: a run whose output cannot be written ends with a
# non-zero exit and a message naming the file and the cause, never hangs, and never loses the
# last good checkpoint (docs/output.md, "Write failures"). CMD is the executable, optionally
# behind a launcher (mpiexec -np 2 .../fabrica).
#   KIND tmpfs:   the output directory is a tmpfs of each size in $SIZES (KB), smaller than the
#                 whole output; needs mount (root): exit 77 (skipped) when mount is refused.
#   KIND ulimit:  a file-size limit (ulimit -f, KB) of each size in $SIZES.
#   KIND readonly: the output directory is read-only (a read-only tmpfs as root, chmod otherwise).
# For each size: exit non-zero within $TIMEOUT s (default 120, times FABRICA_TEST_TIME_FACTOR
# where the sanitizer build sets it; 124 = a hang), stderr names a file
# of the output directory and "cannot"; if the run said it wrote a checkpoint, OUT/checkpoint.ckpt
# is complete (fabrica checkpoint-info reads it, checksum included) and is the last one announced.
set -u
kind=$1 work=$2 scene=$3; shift 3
fabrica=${FABRICA:-${@: -1}}  # the executable (the last word of CMD), for checkpoint-info
timeout=${TIMEOUT:-$((120 * ${FABRICA_TEST_TIME_FACTOR:-1}))}
# Mounts left by an earlier, interrupted run of this test go first.
for m in "$work"/mnt-* "$work"/ro; do mountpoint -q "$m" 2>/dev/null && { umount "$m" || umount -l "$m"; }; done
rm -rf "$work"; mkdir -p "$work"
mounted=()
cleanup() {
  for m in "${mounted[@]}"; do
    for _ in 1 2 3 4 5; do umount "$m" 2>/dev/null && break; sleep 0.5; done
    mountpoint -q "$m" && umount -l "$m"
  done
}
trap cleanup EXIT
fail() { echo "FAIL: $*"; exit 1; }

check_one() {  # check_one LABEL OUTDIR LOG RC
  local label=$1 out=$2 log=$3 rc=$4
  [ "$rc" -ne 124 ] || fail "$label: no exit within $timeout s (a hang)"
  # The sanitizer build: a report in the failed run's log fails the test (the log is not shown).
  ! grep -Eq "ERROR: (Address|Leak)Sanitizer|: runtime error: " "$log" ||
    { grep -E -A30 "ERROR: (Address|Leak)Sanitizer|: runtime error: " "$log"; fail "$label: a sanitizer report"; }
  [ "$rc" -ne 0 ] || { tail -5 "$log"; fail "$label: exit 0 although the output could not be written"; }
  grep -Eq "fabrica: error.*(${out//\//\\/}|$(basename "$out")).*cannot" "$log" ||
    { tail -20 "$log"; fail "$label: no message naming a file of $out and the cause"; }
  local last
  last=$(sed -n 's/^-- checkpoint at step \([0-9]*\):.*/\1/p' "$log" | tail -1)
  if [ -n "$last" ]; then
    local info
    info=$("$fabrica" checkpoint-info "$out/checkpoint.ckpt" 2>&1) ||
      { echo "$info"; fail "$label: the last good checkpoint (step $last) is lost or damaged"; }
    grep -Eq "^  step +$last$" <<<"$info" || { echo "$info"; fail "$label: checkpoint.ckpt is not the last announced one (step $last)"; }
  fi
  # The snapshots written before the failure stay readable (fabrica info reads every one's listing).
  if [ -e "$out/run.h5" ]; then
    "$fabrica" info "$out/run.h5" >"$out.info" 2>&1 || { cat "$out.info"; fail "$label: run.h5 is unreadable after the failure"; }
  fi
  echo "ok $label: exit $rc, checkpoint ${last:-none}: $(grep -m1 'fabrica: error' "$log" | cut -c1-200)"
}

case $kind in
  tmpfs)
    for kb in ${SIZES:-64 128 192 256 384 512 768}; do
      mnt=$work/mnt-$kb; mkdir -p "$mnt"
      if ! mount -t tmpfs -o size=${kb}k tmpfs "$mnt" 2>/dev/null; then
        echo "skipped: cannot mount a tmpfs here (needs root and mount permission)"; exit 77
      fi
      mounted+=("$mnt")
      timeout -k 5 "$timeout" "$@" run "$scene" -o "$mnt/out" >"$work/$kb.log" 2>&1; rc=$?
      check_one "tmpfs ${kb} KB" "$mnt/out" "$work/$kb.log" $rc
    done ;;
  ulimit)
    # Open MPI's shared-memory store (PMIx) and transport create files larger than the limit in
    # MPI_Init: the hash store and TCP between ranks keep MPI within it.
    export PMIX_MCA_gds=hash OMPI_MCA_btl=self,tcp
    for kb in ${SIZES:-16 48 96 160 320 640}; do
      out=$work/out-$kb
      ( ulimit -f "$kb"; exec timeout -k 5 "$timeout" "$@" run "$scene" -o "$out" ) >"$work/$kb.log" 2>&1; rc=$?
      check_one "ulimit -f ${kb} KB" "$out" "$work/$kb.log" $rc
    done ;;
  readonly)
    mnt=$work/ro; mkdir -p "$mnt"
    if [ "$(id -u)" = 0 ]; then
      if ! mount -t tmpfs -o size=1m,ro tmpfs "$mnt" 2>/dev/null; then
        echo "skipped: cannot mount a read-only tmpfs here"; exit 77
      fi
      mounted+=("$mnt")
    else
      chmod 555 "$mnt"
    fi
    timeout -k 5 "$timeout" "$@" run "$scene" -o "$mnt" >"$work/ro.log" 2>&1; rc=$?
    check_one "read-only directory" "$mnt" "$work/ro.log" $rc
    grep -q "Read-only file system\|Permission denied" "$work/ro.log" || fail "the cause is not named"
    [ -z "$(ls -A "$mnt")" ] || fail "files appeared in the read-only directory" ;;
  *) echo "unknown kind $kind"; exit 2 ;;
esac
