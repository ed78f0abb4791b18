#!/usr/bin/env python3
"""flip_bit.py SRC DST DATASET: copies the run file SRC to DST with one bit of DATASET's stored
data flipped (bit 3 of the byte in the middle of its first chunk), as a disk or a copy might do.
DATASET "last:CASE:REL" is REL (e.g. contacts/fn) in the last snapshot of case CASE. Prints the
dataset's path. Exit 77 (skipped) without h5py."""
import shutil
import sys

try:
    import h5py
except ImportError:
    print("skipped: /usr/bin/python3 has no h5py (python3-h5py)")
    sys.exit(77)

src, dst, name = sys.argv[1:4]
with h5py.File(src, "r") as f:
    if name.startswith("last:"):
        _, case, rel = name.split(":", 2)
        name = f"/snapshots/{case}/{sorted(f['snapshots'][case].keys())[-1]}/{rel}"
    d = f[name]
    if d.chunks is None:
        sys.exit(f"{name}: not chunked (no checksum to test)")
    info = d.id.get_chunk_info(0)
    offset = info.byte_offset + info.size // 2
shutil.copyfile(src, dst)
with open(dst, "r+b") as out:
    out.seek(offset)
    b = out.read(1)[0]
    out.seek(offset)
    out.write(bytes([b ^ 0x08]))
print(f"{dst}: bit 3 of byte {offset} flipped ({name}, chunk 0 of {info.size} bytes at {info.byte_offset})")
