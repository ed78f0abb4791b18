#!/usr/bin/python3
"""cli.output.python_reader: apps/fabrica_h5.py against the C++ reader (io/mpi/snapshot.hpp) on the
same run file, and the contact fields stored for the XDMF line cells.

    check_fabrica_h5.py DUMP_RUN_H5 OUT

DUMP_RUN_H5 is tests/cli/dump_run_h5 (the C++ reader's values as %.17g text); OUT a triaxial run
directory with run.h5 and */fabric.csv. Checked, every value with == (the text round-trips):
the info line, every series (columns, values, steps, stages), every snapshot's attributes (the
cell matrix: diag(cell_lengths) in this orthorhombic run), particles and contacts. Then, per snapshot: ft_norm and mr_norm equal |ft| and |mr| to 1e-14
relative to the largest; ends[:, 0] is the centre of body 1 and ends[:, 1] = ends[:, 0] + branch
exactly; and at the steps where the run's fabric analysis (OUT/<case>/fabric.csv) has a row,
the stored strong / sliding / rolling flags count as many contacts as its networks sf, s, r.
Errors: a missing file and a foreign HDF5 file raise FabricaFileError naming the file.
Exit 0 on success, 1 with a message on the first mismatch.
"""
import csv
import os
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "apps"))
import fabrica_h5  # noqa: E402


def fail(msg):
    print(f"check_fabrica_h5: FAIL: {msg}")
    sys.exit(1)


def same(what, a, b):
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape or not np.array_equal(a, b):
        fail(f"{what}: Python {a.ravel()[:6]} (shape {a.shape}) != C++ {b.ravel()[:6]} (shape {b.shape})")


def parse_dump(text):
    series, snaps, info = {}, [], None
    cur = None
    for line in text.splitlines():
        tag, _, rest = line.partition(" ")
        f = rest.split(" ")
        if tag == "info":
            info = (int(f[0]), f[1], f[2], " ".join(f[3:]))
        elif tag == "series":
            cur = {"columns": f[2].split(",") if f[2] else [], "values": {}, "step": [], "stage": []}
            series[f[0]] = cur
        elif tag == "col":
            cur["values"][f[0]] = np.array([float(v) for v in f[1:] if v], dtype=np.float64)
        elif tag == "step":
            cur["step"] = np.array([int(v) for v in f if v], dtype=np.int64)
        elif tag == "stage":
            cur["stage"] = [v for v in f if v]
        elif tag == "snapshot":
            v = [float(x) for x in f[2:]]
            snaps.append({"case": f[0], "step": int(f[1]), "time": v[0], "cell": v[1:4], "strain": v[4:7],
                          "matrix": v[7:16], "N": int(f[-2]), "M": int(f[-1]), "particles": [], "contacts": []})
        elif tag == "particle":
            snaps[-1]["particles"].append([float(x) for x in f])
        elif tag == "contact":
            snaps[-1]["contacts"].append([float(x) for x in f])
    return info, series, snaps


def fabric_counts(out):
    """{(case, step): {network: count}} of every OUT/<case>/fabric.csv row."""
    counts = {}
    for case in os.listdir(out):
        p = os.path.join(out, case, "fabric.csv")
        if not os.path.isfile(p):
            continue
        with open(p) as fh:
            for row in csv.DictReader(fh):
                counts.setdefault((case, int(row["step"])), {})[row["network"]] = int(row["count"])
    return counts


def main():
    dump, out = sys.argv[1], sys.argv[2]
    h5 = os.path.join(out, "run.h5")
    r = subprocess.run([dump, h5], capture_output=True, text=True)
    if r.returncode != 0:
        fail(f"dump_run_h5 failed: {r.stderr}")
    info, series, snaps = parse_dump(r.stdout)
    run = fabrica_h5.RunFile(h5)

    ri = run.info()
    same("info", [ri.mpi_ranks, ri.version, ri.git_describe, ri.scene_path], list(info))
    if sorted(series) != run.series_cases():
        fail(f"series cases: Python {run.series_cases()}, C++ {sorted(series)}")
    for case, s in series.items():
        ps = run.series(case)
        if ps.columns != s["columns"]:
            fail(f"series {case}: columns {ps.columns} != {s['columns']}")
        for c in s["columns"]:
            same(f"series {case} column {c}", ps[c], s["values"][c])
        same(f"series {case} step", ps.step, s["step"])
        if ps.stage != s["stage"]:
            fail(f"series {case}: stages differ")

    pinfo = run.snapshots()
    if [(i.case, i.step) for i in pinfo] != [(s["case"], s["step"]) for s in snaps]:
        fail("the lists of snapshots differ")
    fabric = fabric_counts(out)
    compared = 0
    for i, s in zip(pinfo, snaps):
        where = f"snapshot {s['case']} step {s['step']}"
        same(f"{where} time, cell, strain, N, M", [i.time, *i.cell_lengths, *i.strain, i.particles, i.contacts],
             [s["time"], *s["cell"], *s["strain"], s["N"], s["M"]])
        same(f"{where} cell matrix", i.cell_matrix.ravel(), s["matrix"])
        if i.sheared:  # an orthorhombic cell's matrix is diag(cell_lengths)
            fail(f"{where}: the cell of this run is orthorhombic, its matrix {i.cell_matrix.ravel()}")
        p = run.particles(i.case, i.step)
        cp = np.array(s["particles"]).reshape(-1, 11)
        same(f"{where} particle ids", p.id, cp[:, 0].astype(np.int64))
        same(f"{where} positions", p.position, cp[:, 1:4])
        same(f"{where} velocities", p.velocity, cp[:, 4:7])
        same(f"{where} spins", p.spin, cp[:, 7:10])
        same(f"{where} radii", p.radius, cp[:, 10])
        c = run.contacts(i.case, i.step)
        cc = np.array(s["contacts"]).reshape(-1, 18)
        same(f"{where} id1", c.id1, cc[:, 0].astype(np.int64))
        same(f"{where} id2", c.id2, cc[:, 1].astype(np.int64))
        same(f"{where} normal", c.normal, cc[:, 2:5])
        same(f"{where} branch", c.branch, cc[:, 5:8])
        same(f"{where} overlap", c.overlap, cc[:, 8])
        same(f"{where} fn", c.fn, cc[:, 9])
        same(f"{where} ft", c.ft, cc[:, 10:13])
        same(f"{where} mr", c.mr, cc[:, 13:16])
        same(f"{where} sliding", c.sliding, cc[:, 16] != 0)
        same(f"{where} rolling", c.rolling, cc[:, 17] != 0)
        # The fields of the contacts' XDMF sidecar.
        for name, stored, vec in (("ft_norm", c.ft_norm, c.ft), ("mr_norm", c.mr_norm, c.mr)):
            ref = np.linalg.norm(vec, axis=1)
            scale = max(ref.max(initial=0.0), 1e-300)
            if np.abs(stored - ref).max(initial=0.0) > 1e-14 * scale:
                fail(f"{where}: {name} differs from |vector| by {np.abs(stored - ref).max()}")
        x1 = p.position[np.searchsorted(p.id, c.id1)]
        same(f"{where} ends[:, 0] (centre of body 1)", c.ends[:, 0], x1)
        same(f"{where} ends[:, 1] (x1 + branch)", c.ends[:, 1], x1 + c.branch)
        n = fabric.get((i.case, i.step))
        if n is not None:
            for net, mask in (("sf", c.strong), ("s", c.sliding), ("r", c.rolling)):
                if int(mask.sum()) != n[net]:
                    fail(f"{where}: {int(mask.sum())} contacts flagged {net}, fabric.csv counts {n[net]}")
            compared += 1
    if compared == 0:
        fail("no snapshot at a step of the run's fabric analysis: the strong flags were not compared")

    for bad, msg in ((os.path.join(out, "nope.h5"), "no such file"),
                     (os.path.join(out, "foreign-py.h5"), "not a Fabrica output file")):
        if msg.startswith("not"):
            import h5py
            with h5py.File(bad, "w") as f:
                f["x"] = 1
        try:
            fabrica_h5.RunFile(bad)
            fail(f"{bad}: no error")
        except fabrica_h5.FabricaFileError as e:
            if bad not in str(e) or msg not in str(e):
                fail(f"{bad}: error message {e!r} lacks the file or '{msg}'")
    try:
        run.contacts("mur_0", 7)
        fail("a missing step gave no error")
    except fabrica_h5.FabricaFileError as e:
        if "no snapshot of case 'mur_0' at step 7" not in str(e):
            fail(f"missing step: {e}")
    print(f"check_fabrica_h5: {len(series)} series and {len(snaps)} snapshots identical to the C++ reader; "
          f"strong/sliding/rolling flags match fabric.csv at {compared} steps")


if __name__ == "__main__":
    main()
