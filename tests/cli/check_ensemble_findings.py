#!/usr/bin/python3
"""check_ensemble_findings.py OUT: apps/ensemble_findings.py on an ensemble's output (the
consolidation-frictions test's: two realisations, two mu_r, two consolidation mu_s).
  1. its least-squares slope and 95 % interval equal the textbook formulas written out here
     (b = Sxy / Sxx, se = sqrt(SSE / (n - 2) / Sxx), t(0.975, 3) = 3.182) to 1e-12, on points of
     known scatter; an exact line gives a zero interval; a parabola's quadratic coefficient;
  2. OUT/findings.csv has the twelve findings (and the figures ensemble_trends.png and
     ensemble_consolidation.png are PNG files), each verdict one of the three, the trends decided
     over the 4 points (2 realisations x 2 mu_r) and finding 12 over the 4 consolidations."""
import csv
import math
import os
import subprocess
import sys

here = os.path.dirname(os.path.abspath(__file__))
apps = os.path.join(here, "..", "..", "apps")
sys.path[:0] = [apps, here]
import ensemble_findings as ef  # noqa: E402
from checking import Checks  # noqa: E402

c = Checks()
check = c.close

x = [0.0, 1.0, 2.0, 3.0, 4.0]
y = [1.1, 2.9, 5.2, 7.1, 8.8]
n = len(x)
xm, ym = sum(x) / n, sum(y) / n
sxx = sum((a - xm) ** 2 for a in x)
sxy = sum((a - xm) * (b - ym) for a, b in zip(x, y))
b = sxy / sxx
sse = sum((bb - (ym + b * (a - xm))) ** 2 for a, bb in zip(x, y))
se = math.sqrt(sse / (n - 2) / sxx)
coef, hw = ef.fit(x, y)
check("slope", coef[0], b)
check("half-width", hw[0], 3.182 * se)
coef, hw = ef.fit(x, [2 * a + 1 for a in x])
check("exact line: slope", coef[0], 2.0)
check("exact line: half-width", hw[0], 0.0, 1e-9)
coef, _ = ef.fit(x, [0.5 * a * a - a + 3 for a in x], 2)
check("parabola: quadratic coefficient", coef[0], 0.5)
for lo, hi, want in ((0.1, 0.3, ef.HOLDS), (-0.3, -0.1, ef.FAILS), (-0.1, 0.1, ef.UNDECIDED)):
    c.equal(f"interval [{lo}, {hi}]", ef.sign_verdict(lo, hi), want)

out = sys.argv[1]
subprocess.run(["/usr/bin/python3", os.path.join(apps, "ensemble_findings.py"), out], check=True)
with open(os.path.join(out, "findings.csv")) as fh:
    rows = list(csv.DictReader(fh))
if [int(r["finding"]) for r in rows] != list(range(1, 13)):
    c.fail("findings.csv does not list findings 1 to 12")
for r in rows:
    if r["verdict"] not in (ef.HOLDS, ef.FAILS, ef.UNDECIDED):
        c.fail(f"finding {r['finding']}: verdict '{r['verdict']}'")
    if r["realisations"] != "2":
        c.fail(f"finding {r['finding']}: realisations '{r['realisations']}'")
if "(4 points)" not in rows[9]["numbers"] or "(4 consolidations)" not in rows[11]["numbers"]:
    c.fail("the trends are not decided over the ensemble's points")
for name in ("ensemble_trends.png", "ensemble_consolidation.png"):
    with open(os.path.join(out, "figures", name), "rb") as fh:
        if fh.read(8) != b"\x89PNG\r\n\x1a\n":
            c.fail(f"figures/{name} is not a PNG file")
c.exit()
