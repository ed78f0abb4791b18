#!/usr/bin/python3
"""Which of the study's answers depend on the specimen's size: one larger realisation against an
ensemble of smaller ones (issue 44 item 5; docs/triaxial.md "8 times the size").

    size_effect.py LARGE ENSEMBLE [--no-figures]

LARGE is the output directory of one triaxial run (for instance examples/paper_large.toml),
ENSEMBLE that of a run with [triaxial] realisations (examples/paper_ensemble.toml): every mu_r
of LARGE in each realisation, and the same mu_s of the shear and of the consolidation (else it is
refused with the value that differs). Writes LARGE/size_quantities.csv and LARGE/size_findings.csv and prints them,
and draws LARGE/figures/size_effect.png (q/p and eps_v against eps_1 for each mu_r: LARGE's curve
over the band of 95 % of the ensemble's realisations).

Quantities (size_quantities.csv: quantity, mu_r, large, ensemble_mean, ensemble_sd,
realisations, lower, upper, verdict): for each case, the peak q/p, eps_1 at the peak, the mean
q/p of the residual state (eps_1 >= 0.6 x the final eps_1), the final volumetric strain and the
residual global a_c, a_n, a_c of ns-sf and a_n of sf; and once the void ratio and Z after the
consolidation at LARGE's consolidation mu_s. LARGE's value is set against the 95 % prediction
interval of one more realisation of the ensemble's size,

    mean +- t(0.975, n - 1) s sqrt(1 + 1/n)          (s: the sample standard deviation, n >= 2)

and marked "within" the realisations' spread, or "above" / "below" it: outside, the larger
specimen differs from what another small one would give by more than their own fluctuation, a
size effect at the 95 % level. With some fifty such comparisons about one in twenty falls outside
by chance alone: a size effect is a pattern over the cases, not one row.

Findings (size_findings.csv: finding, ensemble, large, large_one_run, same, large_numbers): the
ensemble's verdict (apps/ensemble_findings.py), and LARGE's own with the same criteria: the
trends in mu_r (findings 7-10) by the slope over its cases and its 95 % interval, a statement
about one state (1-6, 11) as apps/paper_findings.py decides it (its verdict also in
large_one_run, with the study's strict criteria for 7-10). same: yes / no, or "ensemble
undecided" where the realisations disagree (LARGE's verdict is then one more draw). Finding 12
needs several consolidation frictions, which one large run does not have: its void ratio and Z
are compared above instead.
"""
import csv
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import ensemble_findings as ef  # noqa: E402
import paper_data as pd  # noqa: E402
import paper_findings as pf  # noqa: E402

WITHIN, ABOVE, BELOW, SPREAD_UNKNOWN = "within", "above", "below", "fewer than 2 realisations"


def prediction_interval(values):
    """(mean, sd, n, lower, upper): the 95 % interval of one more draw from the values' population."""
    v = np.asarray([x for x in values if math.isfinite(x)], float)
    n = v.size
    if n < 2:
        m = float(v.mean()) if n else float("nan")
        return m, float("nan"), n, float("nan"), float("nan")
    m, s = float(v.mean()), float(v.std(ddof=1))
    h = ef.t975(n - 1) * s * math.sqrt(1.0 + 1.0 / n)
    return m, s, n, m - h, m + h


def place(value, lower, upper):
    if not (math.isfinite(lower) and math.isfinite(upper)):
        return SPREAD_UNKNOWN
    return ABOVE if value > upper else BELOW if value < lower else WITHIN


def residual_q_p(case):
    s = case.shear()
    eps1 = s["eps1"]
    return float(np.mean(s["q_p"][eps1 >= pd.RESIDUAL_FROM * eps1.max()]))


def peak(case):
    s = case.shear()
    i = int(np.argmax(s["q_p"]))
    return float(s["q_p"][i]), float(s["eps1"][i])


# Per case: (name, how it is computed from a paper_data.Case).
CASE_QUANTITIES = [
    ("peak q/p", lambda c: peak(c)[0]),
    ("eps_1 at the peak", lambda c: peak(c)[1]),
    ("residual q/p", residual_q_p),
    ("final eps_v", lambda c: float(c.shear()["epsv"][-1])),
    ("a_c", lambda c: c.res_mean("all", "a_c")),
    ("a_n", lambda c: c.res_mean("all", "a_n")),
    ("a_c of ns-sf", lambda c: c.res_mean("ns-sf", "a_c")),
    ("a_n of sf", lambda c: c.res_mean("sf", "a_n")),
]


def consolidated(run_dir):
    """(void ratio, Z) of the last row of a run's consolidation.csv."""
    with open(os.path.join(run_dir, "consolidation.csv")) as fh:
        last = list(csv.DictReader(fh))[-1]
    return float(last["void_ratio"]), float(last["Z"])


def quantities(large, runs, ens_dirs):
    """The rows of size_quantities.csv."""
    rows = []
    by_mu = {c.mu_r: c for c in large.cases}
    for name, get in CASE_QUANTITIES:
        for mu in sorted(by_mu):
            pts = [get(c) for r in runs for c in r.cases if c.mu_r == mu]
            value = get(by_mu[mu])
            m, s, n, lo, hi = prediction_interval(pts)
            rows.append((name, mu, value, m, s, n, lo, hi, place(value, lo, hi)))
    big = consolidated(large.out)
    small = [consolidated(d) for d in ens_dirs]
    mu_s = large.consolidation_mu_s
    for k, name in enumerate((f"void ratio after consolidation at mu_s = {mu_s:g}", f"Z after consolidation at "
                              f"mu_s = {mu_s:g}")):
        m, s, n, lo, hi = prediction_interval([x[k] for x in small])
        rows.append((name, float("nan"), big[k], m, s, n, lo, hi, place(big[k], lo, hi)))
    return rows


def findings(large, ensemble_rows, runs_of_large):
    """The rows of size_findings.csv."""
    one = {f.number: f for f in pf.decide(large)}
    trends = ef.trend_findings(runs_of_large)
    rows = []
    for n, ens_verdict, *_ in ensemble_rows:
        if n in trends:
            verdict, numbers = trends[n]
        elif n == 12:
            verdict = ef.UNDECIDED
            numbers = "one consolidation friction: see the void ratio and Z in size_quantities.csv"
        else:
            verdict, numbers = one[n].verdict, one[n].numbers
        verdict = ef.UNDECIDED if verdict == pf.UNDECIDED else verdict
        same = ("-" if n == 12 else "ensemble undecided" if ens_verdict == ef.UNDECIDED
                else "yes" if verdict == ens_verdict else "no")
        rows.append((n, ens_verdict, verdict, one[n].verdict, same, numbers))
    return rows


def spheres(run):
    return run.scene.get("particles", {}).get("count", "?")


def figure(large, runs, path):
    """q/p and eps_v against eps_1 for each mu_r: LARGE's curve (dashed) over the band in which 95 %
    of the ensemble's realisations would lie (its mean +- t s sqrt(1 + 1/n), each realisation's
    curve interpolated onto the first one's eps_1), the criterion of size_quantities.csv."""
    import matplotlib
    matplotlib.use("Agg")
    import paper_ensemble as pe
    import plot_paper as pp
    plt = pp.plt
    col = pp.mur_colours(large)
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.8))
    for c in large.cases:
        mine = c.shear()
        others = [o.shear() for r in runs for o in r.cases if o.mu_r == c.mu_r]
        for a, key in ((ax[0], "q_p"), (ax[1], "epsv")):
            scale = 1.0 if key == "q_p" else 100.0
            b = pe.curve_band([100.0 * o["eps1"] for o in others], [scale * o[key] for o in others])
            if b is not None:
                h = b.half_width * np.sqrt(b.n + 1.0)
                a.plot(b.x, b.mean, "-", color=col[c.name], lw=1.0)
                a.fill_between(b.x, b.mean - h, b.mean + h, color=col[c.name], alpha=0.15, lw=0)
            a.plot(100.0 * mine["eps1"], scale * mine[key], "--", color=col[c.name], lw=1.6, label=c.label)
    ax[0].set_ylabel(r"stress ratio $q/p$")
    ax[1].set_ylabel(r"volumetric strain $\varepsilon_v$ (%), compression positive")
    ax[1].axhline(0, color="k", lw=0.5)
    for a in ax:
        a.set_xlabel(pp.EPS1)
        a.plot([], [], "k--", lw=1.6, label=f"{spheres(large)} spheres")
        a.plot([], [], "k-", lw=1.0, label=f"mean of {len(runs)} x {spheres(runs[0])}, band: 95 % of one more")
        a.legend(fontsize=7, ncol=2)
    fig.suptitle("The larger specimen (dashed) against the band of 95 % of the smaller specimen's realisations",
                 fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.94))
    os.makedirs(os.path.dirname(path), exist_ok=True)
    pp.save(fig, path, [])
    return path


def write(path, header, rows):
    with open(path + ".tmp", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        w.writerows(rows)
    os.replace(path + ".tmp", path)
    return path


def mismatch(large, runs, large_dir):
    """Why LARGE cannot be set against the ensemble (a message), or None: every mu_r of LARGE in
    each realisation, the same mu_s of the shear and of the consolidation."""
    for r in runs:
        missing = sorted({c.mu_r for c in large.cases} - {c.mu_r for c in r.cases})
        if missing:
            return f"{r.out}: no case of mu_r = {', '.join(f'{m:g}' for m in missing)} that {large_dir} has"
        for what, a, b in (("friction", large.mu_s, r.mu_s),
                           ("consolidation_friction", large.consolidation_mu_s, r.consolidation_mu_s)):
            if a != b:
                return f"{r.out}: {what} = {b:g}, but {large_dir} has {a:g}: not the same protocol"
    return None


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    flags = [a for a in sys.argv[1:] if a.startswith("--")]
    if len(args) != 2 or any(f != "--no-figures" for f in flags):
        sys.exit(__doc__.splitlines()[0] + "\nusage: size_effect.py LARGE ENSEMBLE [--no-figures]")
    large_dir, ens = args
    if ef.realisations(large_dir):
        sys.exit(f"size_effect.py: {large_dir}: an ensemble; LARGE must be one run")
    ens_dirs = ef.realisations(ens)
    if not ens_dirs:
        sys.exit(f"size_effect.py: {ens}: no realisations (OUT/seed_<s>/); ENSEMBLE must be a run with "
                 "[triaxial] realisations")
    large = pd.load(large_dir)
    runs = [pd.load(d) for d in ens_dirs]
    why = mismatch(large, runs, large_dir)
    if why:
        sys.exit(f"size_effect.py: {why}")
    q = quantities(large, runs, ens_dirs)
    qpath = write(os.path.join(large_dir, "size_quantities.csv"),
                  ["quantity", "mu_r", "large", "ensemble_mean", "ensemble_sd", "realisations", "lower", "upper",
                   "verdict"], q)
    f = findings(large, ef.decide(ens, runs), [large])
    fpath = write(os.path.join(large_dir, "size_findings.csv"),
                  ["finding", "ensemble", "large", "large_one_run", "same", "large_numbers"], f)
    for name, mu, value, m, s, n, lo, hi, v in q:
        at = f" mu_r = {mu:<5g}" if math.isfinite(mu) else ""
        print(f"{name + at:48s} {value:10.4g}  {n} realisations: {m:.4g} +- {s:.2g}, "
              f"95 % of one more in [{lo:.4g}, {hi:.4g}]: {v}")
    for n, e, g, one, same, _ in f:
        print(f"finding {n:2d}: ensemble {e:32s} large {g:32s} same: {same}")
    print(f"written: {qpath}, {fpath}")
    if "--no-figures" not in flags:
        print(f"figure written: {figure(large, runs, os.path.join(large_dir, 'figures', 'size_effect.png'))}")


if __name__ == "__main__":
    main()
