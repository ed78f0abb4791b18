#!/usr/bin/env bash
# restart_corrupt_h5.sh WORKDIR SOURCE_DIR SCENE CMD...: a restart whose OUT/run.h5 is damaged
# stops with a message naming the file (and suggesting to move it aside), exit 1, before
# anything is touched: run.h5, the checkpoint and the CSV series stay as they were, byte for
# byte. SOURCE_DIR is a finished run of SCENE with checkpoints (copied to WORKDIR/run);
# CMD is the executable, optionally behind a launcher (mpiexec -np 2 .../fabrica).
set -u
here=$(cd "$(dirname "$0")" && pwd)
work=$1 src=$2 scene=$3; shift 3
rm -rf "$work"; mkdir -p "$work"
cp -r "$src" "$work/run" || exit 1
out=$work/run
test -s "$out/run.h5" && test -s "$out/checkpoint.ckpt" || { echo "no run.h5 or checkpoint in $src"; exit 1; }
# Damage run.h5: keep its first 2000 bytes (the superblock survives, the rest is gone).
head -c 2000 "$src/run.h5" >"$out/run.h5"
sums() { (cd "$out" && find . -type f | sort | xargs md5sum); }
before=$(sums)
bash "$here/expect_error.sh" "run\.h5: cannot open the HDF5 file.*move it aside" \
  "$@" run "$scene" -o "$out" --restart "$out/checkpoint.ckpt" || exit 1
after=$(sums)
[ "$before" = "$after" ] || { echo "the refused restart changed files:"; diff <(echo "$before") <(echo "$after"); exit 1; }
echo "run.h5, the checkpoint and the CSV files untouched ($(echo "$before" | wc -l) files)"
