"""The output of one triaxial run, loaded for apps/plot_paper.py and its report.

``load(OUT)`` reads the CSV files of the fabric analysis (OUT/<case>/fabric.csv, sff.csv,
rose.csv; docs/fabric.md), the macro series and the snapshots from OUT/run.h5 (through
apps/fabrica_h5.py), OUT/summary.csv and the consolidation files. Cases are ordered by mu_r.
"""
import csv
import glob
import os
import tomllib

import numpy as np

import fabrica_h5
from fabrica_cases import mu_r_of

# The networks as the study names them (docs/fabric.md).
NETWORK_LABELS = {
    "all": "global", "ns": "non-sliding (ns)", "s": "sliding (s)", "r": "rolling (r)",
    "nr": "non-rolling (nr)", "sf": "strong (sf)", "wf": "weak (wf)",
    "ns-nr": "non-sliding non-rolling (ns-nr)", "ns-r": "non-sliding rolling (ns-r)",
    "s-nr": "sliding non-rolling (s-nr)", "s-r": "sliding rolling (s-r)",
    "ns-sf": "non-sliding strong (ns-sf)", "ns-wf": "non-sliding weak (ns-wf)",
    "s-sf": "sliding strong (s-sf)", "s-wf": "sliding weak (s-wf)",
}
NETWORKS = list(NETWORK_LABELS)
PARTITIONS = {"all": ["all"], "ns_s": ["ns", "s"], "sf_wf": ["sf", "wf"], "nr_r": ["nr", "r"],
              "ns_s_nr_r": ["ns-nr", "ns-r", "s-nr", "s-r"],
              "ns_s_sf_wf": ["ns-sf", "ns-wf", "s-sf", "s-wf"]}
PARTITION_LABELS = {p: "{" + ", ".join(n) + "}" for p, n in PARTITIONS.items()}
# The study's residual state: the rows with eps_1 at least this share of the largest eps_1.
RESIDUAL_FROM = 0.6
STUDY_MU_R = 0.05  # the case of the study's figures 3-8


def _table(path):
    d = np.genfromtxt(path, delimiter=",", names=True, dtype=None, encoding="utf-8")
    return np.atleast_1d(d)


class Case:
    """One case of the sweep: its series (shear rows), fabric rows, SFF rows and roses."""

    def __init__(self, out, name, run):
        self.name = name
        self.mu_r = mu_r_of(name)
        d = os.path.join(out, name)
        self.fabric = _table(os.path.join(d, "fabric.csv"))
        self.sff = _table(os.path.join(d, "sff.csv"))
        self.rose = _table(os.path.join(d, "rose.csv"))
        for t in (self.fabric, self.sff, self.rose):
            if t.size == 0:
                raise SystemExit(f"plot_paper.py: {d}: an empty fabric file")
        # Rows of a network whose second-order density is negative somewhere: a_b, a_n, a_t of
        # the network are not meaningful there (docs/fabric.md).
        bad = (self.fabric["nonpositive_weights"] > 0) | ~(self.fabric["min_weight"] > 0)
        for k in ("a_b", "a_n", "a_t"):
            self.fabric[k] = np.where(bad, np.nan, self.fabric[k])
        self.series = run.series(name) if run is not None else None
        self.label = f"$\\mu_r$ = {self.mu_r:g}"   # for the figures (matplotlib mathtext)
        self.text = f"mu_r = {self.mu_r:g}"          # for text

    def net(self, network):
        """The fabric rows of one network, in step order."""
        return self.fabric[self.fabric["network"] == network]

    def residual(self, rows):
        """The mask of the residual-state rows (eps_1 >= RESIDUAL_FROM x the largest eps_1)."""
        return rows["eps1"] >= RESIDUAL_FROM * self.sff["eps1"].max()

    def res_mean(self, network, key):
        """Mean of a column of one network over the residual state (nan if empty)."""
        s = self.net(network)
        v = s[key][self.residual(s)]
        v = v[np.isfinite(v)]
        return float(v.mean()) if v.size else float("nan")

    def shear(self):
        """The series rows of the shear stage: a dict of arrays eps1, epsv, q_p, p, ..."""
        s = self.series
        m = s.rows("shear")
        return {c: s[c][m] for c in s.columns}


class Run:
    def __init__(self, out):
        self.out = out
        dirs = sorted(os.path.dirname(f) for f in glob.glob(os.path.join(out, "*", "fabric.csv")))
        if not dirs:
            raise SystemExit(f"plot_paper.py: no */fabric.csv under {out} (not a triaxial run with [fabric])")
        h5 = os.path.join(out, "run.h5")
        self.h5 = fabrica_h5.RunFile(h5) if os.path.exists(h5) else None
        if self.h5 is None:
            raise SystemExit(f"plot_paper.py: {h5}: missing (the figures need the series and snapshots)")
        names = [os.path.basename(d) for d in dirs]
        self.cases = sorted((Case(out, n, self.h5) for n in names), key=lambda c: (c.mu_r, c.name))
        self.summary = []
        p = os.path.join(out, "summary.csv")
        if os.path.exists(p):
            with open(p) as fh:
                self.summary = list(csv.DictReader(fh))
        self.info = self.h5.info()
        try:
            scene = tomllib.loads(self.info.scene_text)
        except tomllib.TOMLDecodeError as e:
            raise SystemExit(f"plot_paper.py: {h5}: the stored scene does not parse: {e}")
        # The defaults of io/serial/scene.hpp and core/contact_law.hpp for keys the scene leaves out.
        self.mu_s = float(scene.get("contact", {}).get("friction", 0.3))
        self.consolidation_mu_s = float(scene.get("triaxial", {}).get("consolidation_friction", 1.0))
        self.scene = scene

    def reference(self):
        """The case shown in figures 3-8: the one with mu_r nearest to the study's 0.05, among
        those with mu_r > 0 when there are any (with mu_r = 0 every contact rolls: nr is empty)."""
        pool = [c for c in self.cases if c.mu_r > 0] or self.cases
        return min(pool, key=lambda c: abs(c.mu_r - STUDY_MU_R))

    def last_contacts(self, case):
        """The contacts (fabrica_h5.Contacts) of the last snapshot of a case: the end of shear."""
        snaps = self.h5.snapshots(case.name)
        return self.h5.contacts(case.name, snaps[-1].step)


def load(out):
    return Run(out)
