#!/usr/bin/env python3
"""check_summary.py OUT PRESSURE: OUT/summary.csv agrees with the shear rows of each case's
OUT/<case>/series.csv: peak_q_p and eps1_at_peak are those of the row of largest q/p,
max_lateral_error is max |s_ii - PRESSURE| / PRESSURE (i = 2, 3) over the rows, q_p_end is the
last row's; to the summary's 6 decimals (5e-7). Every row counts, the last included."""
import csv
import os
import sys

out, target = sys.argv[1], float(sys.argv[2])
tol = 5e-7
bad = 0
with open(os.path.join(out, "summary.csv")) as f:
    summary = list(csv.DictReader(f))
if not summary:
    sys.exit("summary.csv has no case")
for s in summary:
    with open(os.path.join(out, s["case"], "series.csv")) as f:
        rows = [r for r in csv.DictReader(f) if r["stage"] == "shear"]
    if not rows:
        sys.exit(f"{s['case']}: no shear rows")
    peak = max(rows, key=lambda r: float(r["q_p"]))
    lateral = max(abs(float(r[c]) - target) / target for r in rows for c in ("s22", "s33"))
    expect = {"peak_q_p": float(peak["q_p"]), "eps1_at_peak": float(peak["eps1"]),
              "max_lateral_error": lateral, "q_p_end": float(rows[-1]["q_p"])}
    for k, v in expect.items():
        ok = abs(float(s[k]) - v) <= tol
        bad += not ok
        print(f"{s['case']}: {k} = {s[k]} in summary.csv, {v:.7f} from {len(rows)} shear row(s): {'ok' if ok else 'MISMATCH'}")
sys.exit(1 if bad else 0)
