#!/usr/bin/env bash
# make_bad_checkpoints.sh DIR FABRICA SCENE: runs SCENE (it writes DIR/run/checkpoint.ckpt) and
# derives the bad checkpoints of the cli.checkpoint.* tests from it: truncated (last byte
# gone), corrupted (one byte of the particle data changed), another format version (the
# version field set to 99).
set -eu
dir=$1 fabrica=$2 scene=$3
rm -rf "$dir"; mkdir -p "$dir"
"$fabrica" run "$scene" -o "$dir/run" >"$dir/run.log"
good=$dir/run/checkpoint.ckpt
size=$(stat -c %s "$good")
head -c $((size - 1)) "$good" >"$dir/truncated.ckpt"
cp "$good" "$dir/corrupted.ckpt"
at=$((size / 2))
byte=$(od -An -tu1 -j $at -N1 "$good" | tr -d ' ')
printf "$(printf '\\%03o' $(((byte + 1) % 256)))" | dd of="$dir/corrupted.ckpt" bs=1 seek=$at conv=notrunc status=none
cp "$good" "$dir/version99.ckpt"
printf '\143\000\000\000' | dd of="$dir/version99.ckpt" bs=1 seek=8 conv=notrunc status=none
cmp -s "$good" "$dir/corrupted.ckpt" && { echo "corruption failed"; exit 1; }
echo "made bad checkpoints from $good ($size bytes)"
