#!/usr/bin/python3
"""The study's findings decided over an ensemble of realisations (issue 44 item 3;
docs/triaxial.md "Findings over realisations").

    ensemble_findings.py OUT [--no-figures]

OUT is the output directory of a run with [triaxial] realisations / seeds (OUT/seed_<s>/ each a
triaxial run with its fabric files and run.h5) and, if it had consolidation_friction_cases,
OUT/consolidations.csv. Writes OUT/findings.csv (number, verdict, realisations, numbers,
criterion) and prints it as a table, and draws into OUT/figures/: ensemble_trends.png (peak q/p,
the final volumetric strain and the global a_c and a_n against mu_r: each realisation's points,
their mean and its 95 % band) and, with consolidation frictions, ensemble_consolidation.png (the
void ratio and Z after consolidation against the consolidation mu_s: the study's figure 2(b)).

How each finding is decided:
- a trend in mu_r (findings 7-10): the ordinary least-squares slope of the quantity against mu_r
  over every realisation and case together, with its 95 % confidence interval (Student's t with
  n - 2 degrees of freedom): "grows" holds when the interval lies above 0, does not hold when it
  lies below 0, and is undecided at this ensemble size when it contains 0; "barely changes" holds
  when the change over the swept mu_r range (slope x range, with its interval) stays within
  +-BARELY of the quantity's mean, does not hold when the interval lies wholly outside that band,
  and is undecided otherwise; "A exceeds B in every case": the mean of A - B over every
  realisation and case with its 95 % interval, above 0 (holds), below 0 (does not hold), or
  containing 0 (undecided);
- a statement about one state (findings 1-6, 11): decided on each realisation as
  apps/paper_findings.py decides it; holds if it holds in every realisation, does not hold if in
  none, and is undecided (holding in k of n) otherwise;
- finding 12: the void ratio after consolidation against the consolidation mu_s over every
  realisation (OUT/consolidations.csv): "grows" by the slope's interval as above, "more slowly at
  higher mu_s" by the 95 % interval of the quadratic coefficient of a least-squares parabola (below
  0: holds; above: does not hold; containing 0: undecided).
With one realisation (OUT itself a triaxial run) the findings are apps/paper_findings.py's,
marked "one realisation".
"""
import csv
import glob
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import paper_data as pd  # noqa: E402
import paper_findings as pf  # noqa: E402

HOLDS, FAILS, UNDECIDED = pf.HOLDS, pf.FAILS, "undecided at this ensemble size"

# Two-sided 95 % quantiles of Student's t for 1 to 30 degrees of freedom.
T975 = [12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160, 2.145, 2.131,
        2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048, 2.045, 2.042]


# The criteria as the report states them (apps/paper_report.py), in the module's own terms.
CRITERIA = [
    "A trend in mu_r (findings 7-10): the ordinary least-squares slope of the quantity against mu_r over every "
    "realisation and case together, with its 95 % confidence interval (Student's t, n - 2 degrees of freedom). "
    "\"Grows\" holds when the interval lies above 0, does not hold when it lies below 0, and is undecided at this "
    "ensemble size when it contains 0 (\"decreases\" the same with the signs exchanged).",
    f"\"Barely changes\": the change over the swept mu_r range (the slope's interval times the range) as a share "
    f"of the quantity's mean holds within +-{pf.BARELY:g}, does not hold when the interval lies wholly outside "
    f"that band, and is undecided when it crosses the band's edge.",
    "\"A exceeds B\": the mean of A - B over every realisation and case with its 95 % interval (t, n - 1 "
    "degrees of freedom): above 0 holds, below 0 does not hold, containing 0 undecided.",
    "A finding of several parts holds when every part holds, does not hold when one part does not hold, and is "
    "undecided otherwise.",
    "A statement about one state (findings 1-6 and 11): decided on each realisation as apps/paper_findings.py "
    "decides it on one run (its thresholds in docs/fabric.md); holds if it holds in every realisation, does not "
    "hold if in none, undecided (holding in k of n) otherwise.",
    "Finding 12 (OUT/consolidations.csv): the void ratio after consolidation against the consolidation mu_s: "
    "\"grows\" by the slope's 95 % interval as above, \"more slowly at higher mu_s\" by the 95 % interval of "
    "the quadratic coefficient of a least-squares parabola (below 0 holds, above 0 does not hold, containing 0 "
    "undecided; three consolidation frictions at least).",
]


def t975(df):
    if df < 1:
        return float("nan")
    return T975[df - 1] if df <= 30 else 1.960 + 2.4 / df  # within 2e-3 of the quantile beyond 30


def fit(x, y, degree=1):
    """Least-squares polynomial of the given degree: coefficients (highest first) and their 95 %
    half-widths. NaN when the points cannot determine it."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = np.isfinite(x) & np.isfinite(y)
    x, y = x[ok], y[ok]
    n, k = x.size, degree + 1
    if n <= k or np.unique(x).size < k:
        return np.full(k, np.nan), np.full(k, np.nan)
    A = np.vander(x, k)
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    resid = y - A @ coef
    s2 = float(resid @ resid) / (n - k)
    cov = s2 * np.linalg.inv(A.T @ A)
    return coef, t975(n - k) * np.sqrt(np.diag(cov))


def sign_verdict(lo, hi):
    """HOLDS if the interval lies above 0, FAILS below, UNDECIDED if it contains 0."""
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return UNDECIDED
    return HOLDS if lo > 0 else FAILS if hi < 0 else UNDECIDED


def g4(x):
    return "nan" if not math.isfinite(x) else f"{x:.4g}"


def trend(runs, get):
    """(mu_r, value) over every realisation and case."""
    xs, ys = [], []
    for r in runs:
        for c in r.cases:
            xs.append(c.mu_r)
            ys.append(get(c))
    return xs, ys


def grows(runs, get, name, sign=+1):
    """A trend in mu_r: 'grows' (sign +1) or 'decreases' (sign -1)."""
    x, y = trend(runs, get)
    coef, hw = fit(x, y)
    b, h = coef[0], hw[0]
    v = sign_verdict(sign * b - h, sign * b + h) if math.isfinite(h) else UNDECIDED
    return v, f"{name}: slope {g4(b)} +- {g4(h)} per unit mu_r ({len(x)} points)"


def barely(runs, get, name):
    x, y = trend(runs, get)
    coef, hw = fit(x, y)
    span = (max(x) - min(x)) if x else float("nan")
    mean = abs(float(np.nanmean(y))) if y else float("nan")
    lo, hi = (coef[0] - hw[0]) * span / mean, (coef[0] + hw[0]) * span / mean
    if not (math.isfinite(lo) and math.isfinite(hi)):
        v = UNDECIDED
    elif -pf.BARELY < lo and hi < pf.BARELY:
        v = HOLDS
    elif hi < -pf.BARELY or lo > pf.BARELY:
        v = FAILS
    else:
        v = UNDECIDED
    return v, f"{name}: change over the sweep {g4(lo)} to {g4(hi)} of its mean (band +-{pf.BARELY:g})"


def exceeds(runs, get_a, get_b, name):
    d = [get_a(c) - get_b(c) for r in runs for c in r.cases]
    d = np.asarray([x for x in d if math.isfinite(x)])
    if d.size < 2:
        return UNDECIDED, f"{name}: fewer than 2 points"
    m, h = float(d.mean()), t975(d.size - 1) * float(d.std(ddof=1)) / math.sqrt(d.size)
    return sign_verdict(m - h, m + h), f"{name}: mean difference {g4(m)} +- {g4(h)} ({d.size} points)"


def combine(parts):
    """HOLDS if every part holds, FAILS if any fails, UNDECIDED otherwise; with the parts' numbers."""
    vs = [v for v, _ in parts]
    v = FAILS if FAILS in vs else HOLDS if all(x == HOLDS for x in vs) else UNDECIDED
    return v, "; ".join(f"{t} [{w}]" for w, t in parts)


def res(net, key):
    return lambda c: c.res_mean(net, key)


def trend_findings(runs):
    out = {}
    nets = [n for n in pd.NETWORKS if all(math.isfinite(c.res_mean(n, "a_c")) for r in runs for c in r.cases)]
    out[7] = combine([grows(runs, res(n, "a_c"), f"a_c of {n}") for n in nets])
    out[8] = combine([grows(runs, res("all", "a_n"), "a_n"), grows(runs, res("ns", "a_n"), "a_n^ns"),
                      exceeds(runs, res("all", "a_n"), res("all", "a_c"), "a_n - a_c"),
                      exceeds(runs, res("ns", "a_n"), res("ns", "a_c"), "a_n^ns - a_c^ns"),
                      barely(runs, res("sf", "a_n"), "a_n^sf"), barely(runs, res("ns-sf", "a_n"), "a_n^ns-sf")])
    out[9] = combine([grows(runs, res("ns", "xi"), "xi_ns", -1), grows(runs, res("ns-sf", "xi"), "xi_ns-sf", -1),
                      barely(runs, res("sf", "xi"), "xi_sf")])
    out[10] = combine([grows(runs, lambda c: float(np.max(c.shear()["q_p"])), "peak q/p"),
                       grows(runs, lambda c: float(c.shear()["epsv"][-1]), "eps_v at the end", -1)])
    return out


def finding12(out):
    path = os.path.join(out, "consolidations.csv")
    if not os.path.exists(path):
        return UNDECIDED, "no OUT/consolidations.csv: the run had no consolidation_friction_cases"
    with open(path) as fh:
        rows = list(csv.DictReader(fh))
    x = [float(r["consolidation_friction"]) for r in rows]
    y = [float(r["void_ratio"]) for r in rows]
    c1, h1 = fit(x, y, 1)
    c2, h2 = fit(x, y, 2)
    g = (sign_verdict(c1[0] - h1[0], c1[0] + h1[0]),
         f"void ratio against mu_s: slope {g4(c1[0])} +- {g4(h1[0])} ({len(x)} consolidations)")
    s = (sign_verdict(-c2[0] - h2[0], -c2[0] + h2[0]), f"quadratic coefficient {g4(c2[0])} +- {g4(h2[0])}")
    return combine([g, s])


def band(ax, x, ys, label, color):
    """Each realisation's points, the mean over them at each x and its 95 % band (t interval)."""
    xs = sorted(set(x))
    for y in ys:
        ax.plot(x, y, "o", ms=3, color=color, alpha=0.45)
    mean, lo, hi = [], [], []
    for v in xs:
        pts = np.asarray([y[i] for y in ys for i in range(len(x)) if x[i] == v and math.isfinite(y[i])])
        m = float(pts.mean()) if pts.size else float("nan")
        h = t975(pts.size - 1) * float(pts.std(ddof=1)) / math.sqrt(pts.size) if pts.size > 1 else 0.0
        mean.append(m), lo.append(m - h), hi.append(m + h)
    ax.plot(xs, mean, "-", color=color, label=label)
    ax.fill_between(xs, lo, hi, color=color, alpha=0.2, lw=0)


def figures(out, runs):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    d = os.path.join(out, "figures")
    os.makedirs(d, exist_ok=True)
    written = []
    x = [c.mu_r for c in runs[0].cases]
    if all([c.mu_r for c in r.cases] == x for r in runs):
        fig, axs = plt.subplots(1, 3, figsize=(13, 3.8))
        band(axs[0], x, [[float(np.max(c.shear()["q_p"])) for c in r.cases] for r in runs], "peak q/p", "C0")
        band(axs[1], x, [[100 * float(c.shear()["epsv"][-1]) for c in r.cases] for r in runs], "eps_v at the end",
             "C1")
        band(axs[2], x, [[c.res_mean("all", "a_c") for c in r.cases] for r in runs], "a_c", "C2")
        band(axs[2], x, [[c.res_mean("all", "a_n") for c in r.cases] for r in runs], "a_n", "C3")
        for ax, y in zip(axs, ("peak q/p", "volumetric strain at the end (%)", "residual anisotropy")):
            ax.set_xlabel("mu_r")
            ax.set_ylabel(y)
            ax.legend(fontsize=8)
        fig.suptitle(f"{len(runs)} realisations: each one's points, their mean and its 95 % band")
        fig.tight_layout()
        path = os.path.join(d, "ensemble_trends.png")
        fig.savefig(path, dpi=110)
        plt.close(fig)
        written.append(path)
    cpath = os.path.join(out, "consolidations.csv")
    if os.path.exists(cpath):
        with open(cpath) as fh:
            rows = list(csv.DictReader(fh))
        seeds = sorted({r["seed"] for r in rows})
        mus = sorted({float(r["consolidation_friction"]) for r in rows})
        get = {(r["seed"], float(r["consolidation_friction"])): r for r in rows}
        fig, axs = plt.subplots(1, 2, figsize=(9, 3.8))
        for ax, key, label in ((axs[0], "void_ratio", "void ratio after consolidation"), (axs[1], "Z", "Z")):
            ys = [[float(get[(s, m)][key]) if (s, m) in get else float("nan") for m in mus] for s in seeds]
            band(ax, mus, ys, label, "C0")
            ax.set_xlabel("consolidation mu_s")
            ax.set_ylabel(label)
        fig.suptitle(f"{len(seeds)} realisations (the study's figure 2(b))")
        fig.tight_layout()
        path = os.path.join(d, "ensemble_consolidation.png")
        fig.savefig(path, dpi=110)
        plt.close(fig)
        written.append(path)
    return written


def realisations(out):
    """The realisations' directories OUT/seed_<s>/, in increasing seed."""
    dirs = [d for d in glob.glob(os.path.join(out, "seed_*"))
            if os.path.isdir(d) and "_consolidation_" not in os.path.basename(d)]
    key = lambda d: (0, int(d.rsplit("_", 1)[1]), d) if d.rsplit("_", 1)[1].isdigit() else (1, 0, d)  # noqa: E731
    return sorted(dirs, key=key)


def decide(out, runs=None):
    """The twelve rows (finding, verdict, realisations, numbers, criterion) of OUT's ensemble, or
    of OUT itself when it is one run; runs: the realisations already loaded (paper_data.load)."""
    dirs = realisations(out)
    rows = []
    if not dirs:  # one realisation: the run's own verdicts
        run = pd.load(out)
        for f in pf.decide(run):
            rows.append((f.number, f.verdict, "one realisation", f.numbers, f.criterion))
        return rows
    runs = runs if runs is not None else [pd.load(d) for d in dirs]
    per = [pf.decide(r) for r in runs]
    trends = trend_findings(runs) if len({c.mu_r for c in runs[0].cases}) > 1 else {}
    for k in range(12):
        n = k + 1
        if n in trends:
            v, numbers = trends[n]
            rows.append((n, v, f"{len(runs)}", numbers, "slopes in mu_r over every realisation and case with "
                         "95 % intervals (ensemble_findings.py)"))
        elif n == 12:
            v, numbers = finding12(out)
            rows.append((n, v, f"{len(runs)}", numbers, "least-squares line and parabola of the void ratio "
                         "against the consolidation mu_s, 95 % intervals"))
        else:
            vs = [p[k].verdict for p in per]
            held = sum(v == pf.HOLDS for v in vs)
            v = HOLDS if held == len(vs) else FAILS if held == 0 else UNDECIDED
            rows.append((n, v, f"{len(runs)}", f"holds in {held} of {len(vs)} realisations; first: "
                         + per[0][k].numbers, per[0][k].criterion + " (in every realisation)"))
    return rows


def write(out, rows):
    """OUT/findings.csv (finding, verdict, realisations, numbers, criterion); returns its path."""
    path = os.path.join(out, "findings.csv")
    with open(path + ".tmp", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["finding", "verdict", "realisations", "numbers", "criterion"])
        w.writerows(rows)
    os.replace(path + ".tmp", path)
    return path


def main():
    args = [a for a in sys.argv[1:] if a != "--no-figures"]
    if len(args) != 1:
        sys.exit(__doc__.splitlines()[0] + "\nusage: ensemble_findings.py OUT [--no-figures]")
    out = args[0]
    dirs = realisations(out)
    runs = [pd.load(d) for d in dirs]
    rows = decide(out, runs if dirs else None)
    path = write(out, rows)
    for n, v, r, numbers, _ in rows:
        print(f"{n:2d}  {v:32s}  {numbers[:150]}")
    print(f"findings written to {path}")
    if dirs and "--no-figures" not in sys.argv:
        for w in figures(out, runs):
            print(f"figure written: {w}")


if __name__ == "__main__":
    main()
