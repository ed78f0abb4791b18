#!/usr/bin/python3
"""The run.h5 of a run killed and restarted from a checkpoint against the uninterrupted run's
(tests/cli/restart_after_kill.sh), with h5py:

    check_restart_h5.py FULL_DIR RESTARTED_DIR [--rounding]

  - the same snapshots (case and step), every dataset and attribute of each equal bit for bit
    (the particle positions of the last snapshot are named in the report);
  - the same series cases, columns and rows; step and stage equal, the values bit for bit (NaN,
    the column localisation at rows without a strain increment, equal to NaN);
  - the field instants of [fields] (/fields/<case>/<step>), every dataset and attribute equal
    bit for bit;
  - run.xmf (and run_<case>.xmf, run_fields.xmf) the same text.
With --rounding (a restart on another number of ranks): the series values (sums over ranks in
another order) within a relative 1e-8 of the column's largest magnitude; the snapshots must still
be equal bit for bit (the trajectory does not depend on the number of ranks).

Exits 77 (ctest: skipped) when the Python running it lacks h5py or numpy.
"""
import glob
import os
import sys

try:
    import h5py
    import numpy as np
except ImportError as e:
    print(f"check_restart_h5.py: skipped: {e} (install python3-h5py and python3-numpy)")
    sys.exit(77)


def fail(msg):
    print(f"check_restart_h5.py: FAIL: {msg}")
    sys.exit(1)


def snapshots(f):
    r = []
    if "snapshots" in f:
        for c in f["snapshots"]:
            for s in f["snapshots"][c]:
                r.append((c, s))
    return sorted(r)


def same(u, w):
    """Equal values, NaN equal to NaN (the series' localisation column at rows without it)."""
    return np.array_equal(u, w, equal_nan=u.dtype.kind == "f")


def close(u, w, rel):
    if u.shape != w.shape:
        return False
    if u.dtype.kind != "f" or u.size == 0:
        return np.array_equal(u, w)
    nan = np.isnan(u)
    if not np.array_equal(nan, np.isnan(w)):
        return False
    u, w = u[~nan], w[~nan]
    if u.size == 0:
        return True
    scale = max(float(np.max(np.abs(u))), float(np.max(np.abs(w))), 1e-300)
    return float(np.max(np.abs(u - w))) <= rel * scale


def main():
    if len(sys.argv) < 3:
        fail("usage: check_restart_h5.py FULL_DIR RESTARTED_DIR [--rounding]")
    da, db = sys.argv[1], sys.argv[2]
    rounding = "--rounding" in sys.argv[3:]
    pa, pb = os.path.join(da, "run.h5"), os.path.join(db, "run.h5")
    a, b = h5py.File(pa, "r"), h5py.File(pb, "r")
    sa, sb = snapshots(a), snapshots(b)
    if sa != sb:
        fail(f"snapshots differ:\n  uninterrupted {sa}\n  restarted     {sb}")
    values = 0
    for c, s in sa:
        ga, gb = a["snapshots"][c][s], b["snapshots"][c][s]
        for k, v in ga.attrs.items():
            if k not in gb.attrs:
                fail(f"/snapshots/{c}/{s}: no attribute {k} in the restarted run")
            if not np.array_equal(v, gb.attrs[k]):
                fail(f"/snapshots/{c}/{s} attribute {k}: {v} != {gb.attrs[k]}")
        for part in ("particles", "contacts"):
            if sorted(ga[part]) != sorted(gb[part]):
                fail(f"/snapshots/{c}/{s}/{part}: other datasets")
            for d in ga[part]:
                u, w = ga[part][d][()], gb[part][d][()]
                if not (u.shape == w.shape and u.dtype == w.dtype and u.tobytes() == w.tobytes()):
                    fail(f"/snapshots/{c}/{s}/{part}/{d} differs")
                values += u.size
    if sa:
        c, s = sa[-1]
        n = a["snapshots"][c][s]["particles/position"].shape[0]
        print(f"  last snapshot {c}/{s}: {n} particle positions bit for bit equal")
    # The field instants of [fields] (/fields/<case>/<step>): the same, bit for bit.
    fa = []
    if "fields" in a:
        a["fields"].visit(fa.append)
    fb = []
    if "fields" in b:
        b["fields"].visit(fb.append)
    if sorted(fa) != sorted(fb):
        fail(f"field instants differ:\n  uninterrupted {sorted(fa)}\n  restarted     {sorted(fb)}")
    for name in fa:
        x, y = a["fields"][name], b["fields"][name]
        for k in x.attrs:
            if k not in y.attrs or not np.array_equal(np.asarray(x.attrs[k]), np.asarray(y.attrs[k])):
                fail(f"/fields/{name}: attribute {k} differs")
        if isinstance(x, h5py.Dataset):
            if x[()].tobytes() != y[()].tobytes():
                fail(f"/fields/{name} differs")
            values += x.size
    if fa:
        print(f"  {sum(1 for n in fa if n.count('/') == 1)} field instants bit for bit equal")
    ca = sorted(a["series"]) if "series" in a else []
    cb = sorted(b["series"]) if "series" in b else []
    if ca != cb:
        fail(f"series cases differ: {ca} vs {cb}")
    rows = 0
    for c in ca:
        ga, gb = a["series"][c], b["series"][c]
        if ga.attrs["columns"] != gb.attrs["columns"] or sorted(ga) != sorted(gb):
            fail(f"/series/{c}: other columns")
        for d in ga:
            u, w = ga[d][()], gb[d][()]
            if u.shape != w.shape:
                fail(f"/series/{c}/{d}: {u.shape[0]} rows vs {w.shape[0]} in the restarted run")
            exact = d in ("step", "stage") or not rounding
            if not (same(u, w) if exact else close(u, w, 1e-8)):
                k = int(np.argmax(u != w))
                fail(f"/series/{c}/{d}: row {k}: {u[k]} vs {w[k]}")
            if d == "stage" and ga[d].attrs.get("labels") != gb[d].attrs.get("labels"):
                fail(f"/series/{c}/stage: labels {ga[d].attrs.get('labels')} vs {gb[d].attrs.get('labels')}")
        rows += ga["step"].shape[0]
    xa = sorted(os.path.basename(p) for p in glob.glob(os.path.join(da, "run*.xmf")))
    xb = sorted(os.path.basename(p) for p in glob.glob(os.path.join(db, "run*.xmf")))
    if xa != xb:
        fail(f"XDMF files differ: {xa} vs {xb}")
    for x in xa:
        with open(os.path.join(da, x)) as fa, open(os.path.join(db, x)) as fb:
            if fa.read() != fb.read():
                fail(f"{x}: differs")
    print(f"run.h5 of the restarted run equals the uninterrupted run's: {len(sa)} snapshots "
          f"({values} values), {len(ca)} series ({rows} rows), {len(xa)} XDMF file(s)"
          f"{' (series values to rounding)' if rounding else ''}")


main()
