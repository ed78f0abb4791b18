#!/usr/bin/python3
"""cli.output.sheared_reader, cli.fabric.sheared_offline: the output of a sheared cell (issue 42).

    check_sheared_output.py reader DUMP_RUN_H5 OUT TMP
    check_sheared_output.py fabric FABRICA OUT TMP

OUT is the output of RunOutputSheared.CellMatrixOutlineAndFields (tests/io/test_run_output.cpp:
a generated specimen under simple shear past a flip of the cell, a snapshot and a series row
every 100 steps, case "shear"); TMP a scratch directory (emptied first).

reader: apps/fabrica_h5.py against the C++ reader (DUMP_RUN_H5, tests/cli/dump_run_h5.cpp) on
every snapshot: time, cell lengths, the cell matrix, particle ids and positions, with == (the
text round-trips); every snapshot but the first (step 0, no tilt yet) is sheared, and a flip
shows (the tilt H21 falls between two snapshots); the particles lie in the slanted cell
(fractional coordinates H^-1 x within 0.02 of [0, 1)); then a copy of run.h5 without the
attribute cell_matrix (a file written before it) reads as diag(cell_lengths) in both readers.
fabric: `fabrica fabric OUT/run.h5 --all` on the sheared snapshots: a row per snapshot, whose
mean stress p (the contacts' f (x) branch summed over the cell's volume, |det H|) equals the
run's p at the same step (the series) to 1e-9.
Exit 0 on success, 1 with a message on the first mismatch, 77 without h5py or numpy.
"""
import csv
import os
import shutil
import subprocess
import sys

try:
    import h5py
    import numpy as np
except ImportError as e:
    print(f"check_sheared_output.py: skipped: {e} (install python3-h5py and python3-numpy)")
    sys.exit(77)

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "apps"))
import fabrica_h5  # noqa: E402


def fail(msg):
    print(f"check_sheared_output.py: FAIL: {msg}")
    sys.exit(1)


def dumped_snapshots(dump, h5):
    """{step: (time, lengths (3,), matrix (3, 3), ids, positions)} from the C++ reader."""
    r = subprocess.run([dump, h5], capture_output=True, text=True)
    if r.returncode != 0:
        fail(f"dump_run_h5 {h5}: {r.stderr}")
    out, cur = {}, None
    for line in r.stdout.splitlines():
        tag, _, rest = line.partition(" ")
        f = rest.split(" ")
        if tag == "snapshot":
            v = [float(x) for x in f[2:-2]]
            cur = out[int(f[1])] = (v[0], np.array(v[1:4]), np.array(v[7:16]).reshape(3, 3), [], [])
        elif tag == "particle":
            cur[3].append(int(f[0]))
            cur[4].append([float(x) for x in f[1:4]])
    return out


def reader(dump, outdir, tmp):
    h5 = os.path.join(outdir, "run.h5")
    run = fabrica_h5.RunFile(h5)
    infos = run.snapshots("shear")
    cpp = dumped_snapshots(dump, h5)
    if [i.step for i in infos] != sorted(cpp):
        fail(f"snapshots: Python {[i.step for i in infos]}, C++ {sorted(cpp)}")
    flips = 0
    for k, i in enumerate(infos):
        where = f"snapshot at step {i.step}"
        time, lengths, matrix, ids, pos = cpp[i.step]
        if i.time != time or not np.array_equal(i.cell_lengths, lengths) or not np.array_equal(i.cell_matrix, matrix):
            fail(f"{where}: Python time {i.time}, H {i.cell_matrix.tolist()}; C++ {time}, {matrix.tolist()}")
        if not np.array_equal(np.diag(i.cell_matrix), i.cell_lengths):
            fail(f"{where}: cell_lengths {i.cell_lengths} is not the diagonal of the cell matrix")
        if i.sheared != (k > 0):
            fail(f"{where}: sheared {i.sheared}")
        if k > 0 and i.cell_matrix[1, 0] < infos[k - 1].cell_matrix[1, 0]:
            flips += 1
        p = run.particles("shear", i.step)
        if not np.array_equal(p.id, ids) or not np.array_equal(p.position, np.array(pos)):
            fail(f"{where}: particles differ between the readers")
        s = i.fractional(p.position)
        if s.min() < -0.02 or s.max() > 1.02:
            fail(f"{where}: fractional coordinates from {s.min()} to {s.max()}: not in the slanted cell")
    if flips == 0:
        fail("no flip of the cell between two snapshots (the tilt H21 never falls)")
    # A file written before the attribute: diag(cell_lengths) in both readers.
    shutil.rmtree(tmp, ignore_errors=True)
    os.makedirs(tmp)
    old = os.path.join(tmp, "run.h5")
    shutil.copy(h5, old)
    with h5py.File(old, "r+") as f:
        for g in f["snapshots/shear"].values():
            del g.attrs["cell_matrix"]
    cpp_old = dumped_snapshots(dump, old)
    for i in fabrica_h5.RunFile(old).snapshots("shear"):
        want = np.diag(i.cell_lengths)
        if not np.array_equal(i.cell_matrix, want) or i.sheared or not np.array_equal(cpp_old[i.step][2], want):
            fail(f"without cell_matrix, step {i.step}: Python {i.cell_matrix.tolist()}, "
                 f"C++ {cpp_old[i.step][2].tolist()}, expected diag(cell_lengths)")
    print(f"check_sheared_output.py: {len(infos)} snapshots, the cell matrix the same in both readers "
          f"({len(infos) - 1} sheared, {flips} flip(s)), particles inside the slanted cell; "
          f"a file without cell_matrix reads diag(cell_lengths)")


def fabric(fabrica, outdir, tmp):
    h5 = os.path.join(outdir, "run.h5")
    shutil.rmtree(tmp, ignore_errors=True)
    r = subprocess.run([fabrica, "fabric", h5, "--all", "-o", tmp], capture_output=True, text=True)
    if r.returncode != 0:
        fail(f"fabrica fabric: exit {r.returncode}: {r.stdout}{r.stderr}")
    with open(os.path.join(tmp, "shear", "sff.csv")) as fh:
        rows = {int(row["step"]): float(row["p"]) for row in csv.DictReader(fh)}
    series = fabrica_h5.RunFile(h5).series("shear")
    run_p = dict(zip(series.step.tolist(), series["p"].tolist()))
    steps = [i.step for i in fabrica_h5.RunFile(h5).snapshots("shear")]
    if sorted(rows) != steps:
        fail(f"sff.csv rows at steps {sorted(rows)}, snapshots at {steps}")
    worst = 0.0
    for step, p in rows.items():
        if run_p[step] > 0:
            worst = max(worst, abs(p - run_p[step]) / run_p[step])
    if worst > 1e-9 or not any(p > 0 for p in rows.values()):
        fail(f"the fabric's p against the run's: relative difference up to {worst}")
    print(f"check_sheared_output.py: fabrica fabric on {len(rows)} sheared snapshots, p equal to the run's "
          f"to {worst:.1e}")


def main():
    if len(sys.argv) != 5 or sys.argv[1] not in ("reader", "fabric"):
        sys.exit(__doc__)
    (reader if sys.argv[1] == "reader" else fabric)(*sys.argv[2:])


if __name__ == "__main__":
    main()
