#!/usr/bin/python3
"""check_ensemble_report.py OUT: apps/plot_paper.py on an ensemble's output (the
consolidation-frictions test's: two realisations, two mu_r, two consolidation mu_s) and what it
writes (docs/fabric.md "Figures of the study", docs/triaxial.md "Findings over realisations"):
  1. the figures fig02b and fig03-fig12 and ensemble_trends.png are PNG files, and
     figures/ensemble_bands.csv, findings.csv and report.html exist;
  2. report.html states the ensemble (2 realisations, seeds 3 and 4, 150 spheres, the ranks, the
     groups, the protocol: confining pressure, frictions, strain rate, consolidation frictions),
     every criterion of apps/ensemble_findings.py, and the twelve findings with the verdicts and
     numbers of OUT/findings.csv, each verdict one of the ensemble's three;
  3. the bands of ensemble_bands.csv equal an independent computation from each realisation's
     own files, written out here without numpy: the common eps_1 grid (the first realisation's
     rows within every realisation's range), linear interpolation, the mean and t(0.975, n - 1)
     s / sqrt(n): fig02b (void ratio and Z from OUT/consolidations.csv), fig04 (phi_11, phi_22 of
     ns and the rose shares of ns from seed_*/<case>/fabric.csv and rose.csv), fig09 (a_c of the
     global network, every case), fig11 (xi of ns over the residual state) from the CSV files,
     and fig10 (q/p and eps_v, every case) from each run.h5's /series read with h5py; each to
     1e-12 of the quantity's largest magnitude;
  4. the comparison itself can fail: the same bands with one number moved by 1e-9 of itself,
     and with the half-widths of a normal quantile (1.96) instead of Student's t, are refused."""
import csv
import html.parser
import math
import os
import subprocess
import sys

here = os.path.dirname(os.path.abspath(__file__))
apps = os.path.join(here, "..", "..", "apps")
sys.path.insert(0, apps)
import ensemble_findings as ef  # noqa: E402

T975 = {1: 12.706, 2: 4.303, 3: 3.182, 4: 2.776, 5: 2.571}  # Student's t, two-sided 95 %
TOL = 1e-12
bad = []


def fail(msg):
    bad.append(msg)
    print(f"check_ensemble_report: WRONG: {msg}")


def read(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


# ---- the independent computation --------------------------------------------------------------
def stats(values, t=None):
    v = [x for x in values if math.isfinite(x)]
    n = len(v)
    if n == 0:
        return float("nan"), float("nan"), 0
    m = sum(v) / n
    if n == 1:
        return m, 0.0, 1
    s = math.sqrt(sum((x - m) ** 2 for x in v) / (n - 1))
    return m, (t if t is not None else T975[n - 1]) * s / math.sqrt(n), n


def interp(g, x, y):
    for i in range(len(x) - 1):
        if x[i] <= g <= x[i + 1]:
            if g == x[i]:
                return y[i]
            if g == x[i + 1]:
                return y[i + 1]
            return y[i] + (y[i + 1] - y[i]) * (g - x[i]) / (x[i + 1] - x[i])
    return y[0] if g == x[0] else float("nan")


def curve(xs, ys, t=None):
    """[(x, n, mean, half-width)] of curves, one per realisation, on the common grid."""
    lo, hi = max(x[0] for x in xs), min(x[-1] for x in xs)
    grid = [g for g in xs[0] if lo <= g <= hi]
    return [(g, *reorder(stats([interp(g, x, y) for x, y in zip(xs, ys)], t))) for g in grid]


def reorder(s):
    m, h, n = s
    return n, m, h


def fabric_rows(d, case, net):
    """eps1 and the columns of one network's rows of seed_*/<case>/fabric.csv."""
    return [r for r in read(os.path.join(d, case, "fabric.csv")) if r["network"] == net]


def residual_mean(d, case, net, key):
    sff_eps = [float(r["eps1"]) for r in read(os.path.join(d, case, "sff.csv"))]
    rows = fabric_rows(d, case, net)
    v = [float(r[key]) for r in rows if float(r["eps1"]) >= 0.6 * max(sff_eps)]
    v = [x for x in v if math.isfinite(x)]
    return sum(v) / len(v) if v else float("nan")


def rose_shares(d, case, net):
    rows = read(os.path.join(d, case, "rose.csv"))
    last = rows[-1]["step"]
    r = [x for x in rows if x["step"] == last and x["network"] == net and x["plane"] == "12"][0]
    bins = [int(r[f"bin{k}"]) for k in range(36)]
    merged = [bins[2 * k] + bins[2 * k + 1] for k in range(18)]
    return [c / sum(merged) for c in merged]


def series_h5(d, case, key):
    import h5py
    with h5py.File(os.path.join(d, "run.h5"), "r") as f:
        g = f[f"series/{case}"]
        labels = g["stage"].attrs["labels"]
        labels = (labels.decode() if isinstance(labels, bytes) else str(labels)).split(",")
        shear = [labels[k] == "shear" for k in g["stage"][()]]
        x = [float(v) for v, s in zip(g["eps1"][()], shear) if s]
        y = [float(v) for v, s in zip(g[key][()], shear) if s]
    return x, y


def expected(out, dirs, cases, t=None):
    """{(figure, case, network, quantity): [(x, n, mean, half-width)]} computed here."""
    want = {}
    cons = read(os.path.join(out, "consolidations.csv"))
    mus = sorted({float(r["consolidation_friction"]) for r in cons})
    for key in ("void_ratio", "Z"):
        want[("fig02b", "", "", key)] = [
            (m, *reorder(stats([float(r[key]) for r in cons if float(r["consolidation_friction"]) == m], t)))
            for m in mus]
    ref = "mur_0.2"
    for key in ("phi11", "phi22"):
        rows = [fabric_rows(d, ref, "ns") for d in dirs]
        want[("fig04", ref, "ns", key)] = curve([[float(r["eps1"]) for r in rr] for rr in rows],
                                                [[float(r[key]) for r in rr] for rr in rows], t)
    sh = [rose_shares(d, ref, "ns") for d in dirs]
    want[("fig04", ref, "ns", "rose_share")] = [(k, *reorder(stats([s[k] for s in sh], t))) for k in range(18)]
    for case, mu in cases:
        rows = [fabric_rows(d, case, "all") for d in dirs]
        want[("fig09", case, "all", "a_c")] = curve([[float(r["eps1"]) for r in rr] for rr in rows],
                                                    [[float(r["a_c"]) for r in rr] for rr in rows], t)
        for key in ("q_p", "epsv"):
            xy = [series_h5(d, case, key) for d in dirs]
            want[("fig10", case, "", key)] = curve([a for a, _ in xy], [b for _, b in xy], t)
        want[("fig11", case, "ns", "xi_residual")] = [
            (mu, *reorder(stats([residual_mean(d, case, "ns", "xi") for d in dirs], t)))]
    return want


def compare(got, want, quiet=False):
    """The number of bands of want that got does not match (1e-12 of each quantity's scale)."""
    wrong = 0
    for k, rows in want.items():
        have = got.get(k, [])
        scale = max([abs(v) for r in rows for v in (r[2], r[3]) if math.isfinite(v)] + [1e-300])
        ok = len(have) == len(rows) and len(rows) > 0
        for a, b in zip(have, rows):
            ok = ok and a[0] == b[0] and a[1] == b[1]
            for u, v in ((a[2], b[2]), (a[3], b[3])):
                ok = ok and (abs(u - v) <= TOL * scale or (math.isnan(u) and math.isnan(v)))
        if not ok:
            wrong += 1
            if not quiet:
                fail(f"band {k}: {len(have)} points {have[:2]}... against {len(rows)} computed here {rows[:2]}...")
    return wrong


def bands_file(path):
    got = {}
    for r in read(path):
        k = (r["figure"], r["case"], r["network"], r["quantity"])
        got.setdefault(k, []).append((float(r["x"]), int(r["n"]), float(r["mean"]), float(r["half_width"])))
    return got


# ---- the page ---------------------------------------------------------------------------------
class Page(html.parser.HTMLParser):
    """The cell texts of every table by id, the list items of ol#criteria and the page's text."""

    def __init__(self):
        super().__init__()
        self.tables, self.criteria, self.text = {}, [], []
        self.table = self.row = self.cell = self.item = None
        self.in_criteria = False

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "table":
            self.table = self.tables.setdefault(a.get("id") or f"t{len(self.tables)}", [])
        elif tag == "tr" and self.table is not None:
            self.row = []
            self.table.append(self.row)
        elif tag in ("td", "th") and self.row is not None:
            self.cell = []
        elif tag == "ol" and a.get("id") == "criteria":
            self.in_criteria = True
        elif tag == "li" and self.in_criteria:
            self.item = []

    def handle_endtag(self, tag):
        if tag in ("td", "th") and self.cell is not None:
            self.row.append("".join(self.cell).strip())
            self.cell = None
        elif tag == "table":
            self.table = None
        elif tag == "li" and self.item is not None:
            self.criteria.append("".join(self.item).strip())
            self.item = None
        elif tag == "ol":
            self.in_criteria = False

    def handle_data(self, data):
        self.text.append(data)
        for buf in (self.cell, self.item):
            if buf is not None:
                buf.append(data)


def check_page(out):
    p = Page()
    with open(os.path.join(out, "report.html"), encoding="utf-8") as fh:
        p.feed(fh.read())
    ens = {r[0]: r[1] for r in p.tables.get("ensemble", []) if len(r) >= 2}
    for q, v in (("realisations", "2"), ("seeds", "3, 4"), ("spheres per realisation", "150"),
                 ("MPI ranks per realisation", "1"), ("[parallel] groups", "auto"),
                 ("consolidation frictions of finding 12", "0.2, 1"), ("confining pressure", "200000"),
                 ("mu_s (shear)", "0.3"), ("mu_s (consolidation)", "1"), ("mu_r of the cases", "0, 0.2"),
                 ("axial strain rate", "1")):
        if ens.get(q) != v:
            fail(f"the ensemble table: {q} = {ens.get(q)!r}, expected {v!r}")
    if p.criteria != ef.CRITERIA:
        fail(f"the criteria: {len(p.criteria)} items, not ensemble_findings.CRITERIA ({len(ef.CRITERIA)})")
    rows = [r for r in p.tables.get("findings", [])[1:]]
    csv_rows = read(os.path.join(out, "findings.csv"))
    if len(rows) != 12 or len(csv_rows) != 12:
        fail(f"{len(rows)} findings on the page, {len(csv_rows)} in findings.csv, not 12")
    for r, c in zip(rows, csv_rows):
        if r[0] != c["finding"] or r[2] != c["verdict"] or r[3] != c["numbers"] or r[4] != c["criterion"]:
            fail(f"finding {c['finding']}: the page says {r[:1] + r[2:4]}, findings.csv {c['verdict']}, "
                 f"{c['numbers'][:60]}")
        if r[2] not in (ef.HOLDS, ef.FAILS, ef.UNDECIDED) or c["realisations"] != "2":
            fail(f"finding {c['finding']}: verdict {r[2]!r}, realisations {c['realisations']!r}")
    text = " ".join("".join(p.text).split())
    for s in ("Over 2 realisations", "undecided at this ensemble size", "figures/ensemble_bands.csv",
              "t(0.975, n - 1) s / √n"):
        if s not in text:
            fail(f"the page does not say {s!r}")
    return rows


def main():
    out = sys.argv[1]
    r = subprocess.run(["/usr/bin/python3", os.path.join(apps, "plot_paper.py"), out], capture_output=True, text=True)
    print(r.stdout.strip())
    if r.returncode != 0:
        print(r.stderr)
        sys.exit(1)
    figs = ["fig02b_consolidation", "fig03_force_chains", "fig04_fabric_ns_s", "fig05_fabric_sliding_rolling",
            "fig06_fabric_strong_weak", "fig07_fabric_sliding_strong", "fig08_anisotropy_subnetworks",
            "fig09_anisotropy_vs_mur", "fig10_stress_strain", "fig11_xi_vs_mur", "fig12_sff", "ensemble_trends"]
    for f in figs:
        path = os.path.join(out, "figures", f + ".png")
        with open(path, "rb") as fh:
            if fh.read(8) != b"\x89PNG\r\n\x1a\n":
                fail(f"{path} is not a PNG file")
    rows = check_page(out)

    dirs = [os.path.join(out, "seed_3"), os.path.join(out, "seed_4")]
    cases = [("mur_0", 0.0), ("mur_0.2", 0.2)]
    got = bands_file(os.path.join(out, "figures", "ensemble_bands.csv"))
    want = expected(out, dirs, cases)
    compare(got, want)
    points = sum(len(v) for v in want.values())
    print(f"{len(want)} bands ({points} points) equal to the computation here to {TOL:g} of their scale"
          if not bad else f"{len(bad)} defect(s)")

    # The comparison refuses a wrong band: one number moved by 1e-9 of itself, and the
    # half-widths of a normal quantile instead of Student's t.
    k = ("fig10", "mur_0.2", "", "q_p")
    moved = dict(got)
    x, n, m, h = moved[k][3]
    moved[k] = moved[k][:3] + [(x, n, m * (1 + 1e-9), h)] + moved[k][4:]
    if compare(moved, want, quiet=True) != 1:
        fail("a mean moved by 1e-9 of itself is not refused")
    wrong = compare(got, expected(out, dirs, cases, t=1.96), quiet=True)
    if wrong < len(want) - 1:  # every band with a non-zero half-width differs
        fail(f"half-widths from 1.96 instead of Student's t refused in only {wrong} of {len(want)} bands")
    if not bad:
        print(f"a mean moved by 1e-9 refused; the normal quantile refused in {wrong} of {len(want)} bands")
        print(f"report.html: the ensemble, {len(ef.CRITERIA)} criteria, 12 findings "
              f"({', '.join(r[2] for r in rows)})")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
