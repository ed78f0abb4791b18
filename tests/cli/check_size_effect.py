#!/usr/bin/python3
"""check_size_effect.py ENSEMBLE WORK: apps/size_effect.py on the consolidation-frictions test's
ensemble (two realisations of 150 spheres, mu_r = 0 and 0.2), with a copy of its first
realisation as LARGE.
  1. the 95 % prediction interval equals the textbook formula written out here,
     mean +- t(0.975, n - 1) s sqrt(1 + 1/n) with t(0.975, 4) = 2.776, to 1e-12; one value gives
     no interval; a value above, below and inside is placed so;
  2. LARGE/size_quantities.csv: every quantity at each mu_r and the consolidation's two; the
     peak q/p and the final eps_v of LARGE and of the ensemble's mean and interval equal those
     computed here from the runs' summary.csv files (written by the engine, six decimals) to
     1e-6, the interval's ends to 2e-5 (t(0.975, 1) sqrt(1.5) = 15.6 multiplies that rounding),
     the void ratio and Z from the ensemble's consolidations.csv to 1e-9;
  3. LARGE/size_findings.csv: the twelve findings, the ensemble column equal to
     apps/ensemble_findings.py's verdicts on ENSEMBLE, large_one_run to apps/paper_findings.py's
     on LARGE;
  4. figures/size_effect.png is a PNG file;
  5. another mu_s of the shear or of the consolidation, a mu_r the ensemble lacks, an ensemble
     given as LARGE and a single run as ENSEMBLE are refused by name."""
import csv
import math
import os
import shutil
import statistics
import subprocess
import sys

here = os.path.dirname(os.path.abspath(__file__))
apps = os.path.join(here, "..", "..", "apps")
sys.path[:0] = [apps, here]
import ensemble_findings as ef  # noqa: E402
import paper_data as pd  # noqa: E402
import paper_findings as pf  # noqa: E402
import size_effect as se  # noqa: E402
from checking import Checks  # noqa: E402

c = Checks()
check, expect = c.close, c.equal

v = [1.0, 2.0, 3.0, 4.0, 6.0]
m = sum(v) / 5
s = math.sqrt(sum((x - m) ** 2 for x in v) / 4)
mean, sd, n, lo, hi = se.prediction_interval(v + [float("nan")])
check("mean", mean, m)
check("sd", sd, s)
expect("n", n, 5)
check("lower", lo, m - 2.776 * s * math.sqrt(1.2))
check("upper", hi, m + 2.776 * s * math.sqrt(1.2))
expect("one value: no interval", math.isnan(se.prediction_interval([1.0])[3]), True)
expect("above", se.place(hi + 1e-9, lo, hi), se.ABOVE)
expect("below", se.place(lo - 1e-9, lo, hi), se.BELOW)
expect("inside", se.place(m, lo, hi), se.WITHIN)
expect("no spread", se.place(m, float("nan"), float("nan")), se.SPREAD_UNKNOWN)

ens, work = sys.argv[1], sys.argv[2]
shutil.rmtree(work, ignore_errors=True)
large = os.path.join(work, "large")
shutil.copytree(os.path.join(ens, "seed_3"), large)
app = os.path.join(apps, "size_effect.py")
subprocess.run(["/usr/bin/python3", app, large, ens], check=True)


def rows(path):
    with open(path) as fh:
        return list(csv.DictReader(fh))


q = rows(os.path.join(large, "size_quantities.csv"))
cases = sorted(float(r["rolling_friction"]) for r in rows(os.path.join(large, "summary.csv")))
expect("quantity rows", len(q), len(se.CASE_QUANTITIES) * len(cases) + 2)
for r in q:
    if r["verdict"] not in (se.WITHIN, se.ABOVE, se.BELOW):
        c.fail(f"{r['quantity']} mu_r = {r['mu_r']}: verdict '{r['verdict']}'")
summ = rows(os.path.join(ens, "summary.csv"))
mine = {float(r["rolling_friction"]): r for r in rows(os.path.join(large, "summary.csv"))}
for name, col in (("peak q/p", "peak_q_p"), ("final eps_v", "eps_v_end")):
    for mu in cases:
        got = next(r for r in q if r["quantity"] == name and float(r["mu_r"]) == mu)
        pts = [float(r[col]) for r in summ if float(r["rolling_friction"]) == mu]
        mm, ss = statistics.mean(pts), statistics.stdev(pts)
        h = ef.t975(len(pts) - 1) * ss * math.sqrt(1 + 1 / len(pts))
        check(f"{name} mu_r = {mu:g}: large", float(got["large"]), float(mine[mu][col]), 1e-6)
        check(f"{name} mu_r = {mu:g}: mean", float(got["ensemble_mean"]), mm, 1e-6)
        check(f"{name} mu_r = {mu:g}: lower", float(got["lower"]), mm - h, 2e-5)
        check(f"{name} mu_r = {mu:g}: upper", float(got["upper"]), mm + h, 2e-5)
cons = [r for r in rows(os.path.join(ens, "consolidations.csv")) if float(r["consolidation_friction"]) == 1.0]
expect("consolidations at mu_s = 1", len(cons), 2)
for k, key in ((-2, "void_ratio"), (-1, "Z")):
    pts = [float(r[key]) for r in cons]
    check(f"{key} after consolidation: mean", float(q[k]["ensemble_mean"]), statistics.mean(pts), 1e-9)
    check(f"{key} after consolidation: sd", float(q[k]["ensemble_sd"]), statistics.stdev(pts), 1e-9)

f = rows(os.path.join(large, "size_findings.csv"))
expect("findings", [int(r["finding"]) for r in f], list(range(1, 13)))
ens_rows = ef.decide(ens)
expect("ensemble verdicts", [r["ensemble"] for r in f], [r[1] for r in ens_rows])
expect("LARGE's verdicts as one run", [r["large_one_run"] for r in f], [x.verdict for x in pf.decide(pd.load(large))])
for r in f:
    if r["large"] not in (ef.HOLDS, ef.FAILS, ef.UNDECIDED):
        c.fail(f"finding {r['finding']}: large verdict '{r['large']}'")

with open(os.path.join(large, "figures", "size_effect.png"), "rb") as fh:
    png = fh.read(8) == b"\x89PNG\r\n\x1a\n"
c.true(png, "figures/size_effect.png a PNG file")

runs = [pd.load(d) for d in ef.realisations(ens)]
big = pd.load(large)
c.equal("the same protocol", se.mismatch(big, runs, large), None)
mu_s = big.mu_s
big.mu_s = 0.4
c.true("friction = 0.3, but" in (se.mismatch(big, runs, large) or ""), "another shear mu_s refused")
big.mu_s = mu_s
big.consolidation_mu_s = 0.5
c.true("consolidation_friction = 1, but" in (se.mismatch(big, runs, large) or ""),
       "another consolidation mu_s refused")
big.cases[0].mu_r = 0.123
c.true("no case of mu_r = 0.123" in (se.mismatch(big, runs, large) or ""), "a mu_r the ensemble lacks refused")

for args, message in (([ens, ens], "an ensemble; LARGE must be one run"),
                      ([large, large], "no realisations")):
    p = subprocess.run(["/usr/bin/python3", app] + args, capture_output=True, text=True)
    c.true(p.returncode != 0 and message in p.stderr, f"refused ({message}): {p.stderr.strip()}")
c.exit()
