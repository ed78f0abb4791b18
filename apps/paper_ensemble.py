"""The study's figures 2(b) and 3-12 over an ensemble of realisations, for apps/plot_paper.py
(docs/fabric.md "Figures of the study", docs/triaxial.md "Findings over realisations").

``make_figures(ens, out)`` draws, from the realisations OUT/seed_<s>/ of an ensemble's output,
the figures of plot_paper.py with every curve the ensemble mean and its 95 % band, and writes
the numbers of every band drawn to OUT/figures/ensemble_bands.csv (figure, case, network,
quantity, x, n, mean, half_width). How a band is made:
- at each point, over the n realisations with a finite value there: the mean m and the
  half-width t(0.975, n - 1) s / sqrt(n), s the sample standard deviation (ddof 1); with one
  realisation no band (half-width 0);
- a curve against eps_1: the realisations' rows do not fall at the same strains (each specimen
  has its own time step), so each realisation's curve is interpolated linearly (numpy.interp)
  onto the first realisation's eps_1 values that lie within every realisation's range (from the
  largest first eps_1 to the smallest last one), and the band is taken at those points;
- a rose diagram (figures 4-7): the mean over the realisations of each bin's share of the
  contacts at the end of shear (the bars; its band in the CSV file), with the smallest and the
  largest share over the realisations as thin outlines (with few realisations the band, t times
  wider, would hide the rose);
- figure 3 (force chains) is a snapshot of one specimen: the first realisation's, named in the
  figure;
- figure 2(b): the void ratio and Z after consolidation (OUT/consolidations.csv) against the
  consolidation mu_s, each realisation's points, their mean and its band.
"""
import csv
import math
import os

import numpy as np
import matplotlib.pyplot as plt

import ensemble_findings as ef
import paper_data as pd
import plot_paper as pp
from paper_findings import sff_deviation

BANDS_FILE = "ensemble_bands.csv"


def mean_band(values):
    """Mean and 95 % half-width (t(0.975, n - 1) s / sqrt(n)) of the finite values, and n."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return float("nan"), float("nan"), 0
    m = float(v.mean())
    h = ef.t975(v.size - 1) * float(v.std(ddof=1)) / math.sqrt(v.size) if v.size > 1 else 0.0
    return m, h, int(v.size)


def common_grid(xs):
    """The first curve's x within every curve's range (the x of each curve increasing)."""
    lo, hi = max(x[0] for x in xs), min(x[-1] for x in xs)
    g = np.asarray(xs[0], float)
    return g[(g >= lo) & (g <= hi)]


class Band:
    """A band at points x: mean, half_width and n (arrays)."""

    def __init__(self, x, columns):
        self.x = np.asarray(x, float)
        stats = [mean_band(c) for c in columns]
        self.mean = np.array([s[0] for s in stats])
        self.half_width = np.array([s[1] for s in stats])
        self.n = np.array([s[2] for s in stats])


def curve_band(xs, ys):
    """The band of curves (x_i, y_i), one per realisation, on their common grid; None if no curve."""
    pairs = [(np.asarray(x, float), np.asarray(y, float)) for x, y in zip(xs, ys) if len(x)]
    if not pairs:
        return None
    g = common_grid([x for x, _ in pairs])
    cols = np.array([np.interp(g, x, y) for x, y in pairs])
    return Band(g, cols.T)


class Ensemble:
    """The realisations of an ensemble's output, each loaded by paper_data.load."""

    def __init__(self, out):
        self.out = out
        self.dirs = ef.realisations(out)
        self.seeds = [os.path.basename(d)[len("seed_"):] for d in self.dirs]
        self.runs = [pd.load(d) for d in self.dirs]
        names = [c.name for c in self.runs[0].cases]
        for d, r in zip(self.dirs, self.runs):
            if [c.name for c in r.cases] != names:
                raise SystemExit(f"plot_paper.py: {d}: cases {[c.name for c in r.cases]}, not those of "
                                 f"{self.dirs[0]} ({names})")
        self.names = names
        self.first = self.runs[0]
        self.bands = []

    def cases(self, name):
        """The case ``name`` in every realisation."""
        return [next(c for c in r.cases if c.name == name) for r in self.runs]

    def record(self, figure, case, network, quantity, band):
        for x, n, m, h in zip(band.x, band.n, band.mean, band.half_width):
            self.bands.append((figure, case, network, quantity, x, n, m, h))

    def net_band(self, figure, name, net, key, scale=1.0):
        cs = [c.net(net) for c in self.cases(name)]
        b = curve_band([s["eps1"] for s in cs], [s[key] for s in cs])
        if b is not None:
            self.record(figure, name, net, key, b)
            b.x, b.mean, b.half_width = 100 * b.x, scale * b.mean, scale * b.half_width
        return b

    def series_band(self, figure, name, key, scale=1.0):
        ss = [c.shear() for c in self.cases(name)]
        b = curve_band([s["eps1"] for s in ss], [s[key] for s in ss])
        self.record(figure, name, "", key, b)
        b.x, b.mean, b.half_width = 100 * b.x, scale * b.mean, scale * b.half_width
        return b

    def point_band(self, figure, name, net, quantity, values, x):
        b = Band([x], [values])
        self.record(figure, name, net, quantity, b)
        return b

    def write_bands(self, path):
        with open(path + ".tmp", "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["figure", "case", "network", "quantity", "x", "n", "mean", "half_width"])
            for f, c, net, q, x, n, m, h in self.bands:
                w.writerow([f, c, net, q, f"{x:.17g}", n, f"{m:.17g}", f"{h:.17g}"])
        os.replace(path + ".tmp", path)

    def text(self):
        return f"mean of {len(self.runs)} realisations (seeds {', '.join(self.seeds)}) and its 95 % band"


def draw(ax, b, color, label=None, ls="-", lw=1.4):
    if b is None:
        return
    ax.plot(b.x, b.mean, ls, color=color, lw=lw, label=label)
    ax.fill_between(b.x, b.mean - b.half_width, b.mean + b.half_width, color=color, alpha=0.2, lw=0)


def fig_consolidation(ens, path, written):
    """The study's figure 2(b): void ratio and Z after consolidation against the consolidation mu_s."""
    cpath = os.path.join(ens.out, "consolidations.csv")
    if not os.path.exists(cpath):
        return
    with open(cpath) as fh:
        rows = list(csv.DictReader(fh))
    mus = sorted({float(r["consolidation_friction"]) for r in rows})
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.4))
    for k, (key, label) in enumerate((("void_ratio", "void ratio $e$ after consolidation"),
                                      ("Z", "coordination number $Z$ after consolidation"))):
        cols = [[float(r[key]) for r in rows if float(r["consolidation_friction"]) == m] for m in mus]
        for m, c in zip(mus, cols):
            ax[k].plot([m] * len(c), c, "o", ms=4, color="C0", alpha=0.45)
        b = Band(mus, cols)
        ens.record("fig02b", "", "", key, b)
        ax[k].errorbar(b.x, b.mean, yerr=b.half_width, fmt="-s", color="C3", capsize=4, label="mean, 95 % band")
        ax[k].set_xlabel(r"consolidation friction $\mu_s$")
        ax[k].set_ylabel(label)
        ax[k].set_title(f"({pp.LETTERS[k]}) {label.split(' after')[0]}")
        ax[k].legend()
    seeds = sorted({r["seed"] for r in rows}, key=int)
    fig.suptitle(f"Fig. 2(b)  State after isotropic consolidation against the consolidation friction: "
                 f"{len(seeds)} realisations (seeds {', '.join(seeds)}), points: each realisation", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.93))
    pp.save(fig, path, written)


def mean_rose(ens, figure, name, network):
    """Each realisation's share of the contacts per bin at the end of shear (plane 1-2; 36 bins of
    5 degrees merged into 18 of 10, as on one run), as an array (realisations, bins), and their
    band (recorded); None if the network is empty in every realisation."""
    shares = []
    for c in ens.cases(name):
        r = c.rose
        s = r[(r["step"] == r["step"][-1]) & (r["network"] == network) & (r["plane"].astype(str) == "12")]
        bins = [n for n in r.dtype.names if n.startswith("bin")]
        merge = 2 if len(bins) % 2 == 0 and len(bins) >= 24 else 1
        if s.size:
            v = np.array([s[b][0] for b in bins], float).reshape(-1, merge).sum(axis=1)
            if v.sum() > 0:
                shares.append(v / v.sum())
    if not shares:
        return None
    shares = np.array(shares)
    b = Band(np.arange(shares.shape[1]), shares.T)
    ens.record(figure, name, network, "rose_share", b)
    return shares, b


def rose_panel(ax, ens, figure, name, network, g, letter):
    """The mean rose of a network (bars) with the smallest and largest share of each bin over the
    realisations (thin outlines); g: the global network's (mean_rose), its mean dashed."""
    got = mean_rose(ens, figure, name, network)
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)
    if got is not None:
        shares, b = got
        nb = b.mean.size
        width = np.pi / nb
        theta = (np.arange(nb) + 0.5) * width
        t2 = np.concatenate([theta, theta + np.pi])
        ax.bar(t2, np.concatenate([b.mean, b.mean]), width=width, color=pp.NET_COLOURS.get(network, "C0"),
               alpha=0.75, edgecolor="k", linewidth=0.3)
        for bound in (shares.min(axis=0), shares.max(axis=0)):
            ax.plot(np.concatenate([t2, t2[:1]]), np.concatenate([bound, bound, bound[:1]]), "-", color="0.3",
                    lw=0.6)
        if g is not None:
            gm = g[1].mean
            ax.plot(np.concatenate([t2, t2[:1]]), np.concatenate([gm, gm, gm[:1]]), "k--", lw=0.9)
        ax.set_ylim(0, None)
    else:
        ax.text(0.5, 0.5, "no contacts", transform=ax.transAxes, ha="center")
    ax.set_xticks(np.radians([0, 90, 180, 270]))
    ax.set_xticklabels(["axis 1", "axis 2", "", ""], fontsize=8)
    ax.tick_params(labelsize=7)
    ax.set_title(f"({letter}) {pd.NETWORK_LABELS[network]}\ncontact normals at the end, plane 1-2: mean share\n"
                 f"per bin over {len(ens.runs)} realisations (thin: smallest, largest)", fontsize=9)


def fig_fabric(ens, networks, number, title, path, written):
    name = ens.first.reference().name
    label = ens.first.reference().label
    n = len(networks)
    fig = plt.figure(figsize=(4.6 * n, 9.0))
    fig_id = f"fig{number:02d}"
    glob = {key: ens.net_band(fig_id, name, "all", key) for key in ("phi11", "phi22", "phi33")}
    grose = mean_rose(ens, fig_id, name, "all")
    for k, net in enumerate(networks):
        ax = fig.add_subplot(2, n, k + 1)
        for key in ("phi11", "phi22", "phi33"):
            draw(ax, ens.net_band(fig_id, name, net, key), pp.PHI_COLOURS[key],
                 f"{pp.PHI_LABELS[key]} of the network", lw=1.6)
            ax.plot(glob[key].x, glob[key].mean, "--", color=pp.PHI_COLOURS[key], lw=1.0,
                    label=f"{pp.PHI_LABELS[key]} global")
        ax.axhline(1 / 3, color="0.4", lw=0.6, ls=":")
        ax.set_title(f"({pp.LETTERS[k]}) {pd.NETWORK_LABELS[net]}")
        ax.set_xlabel(pp.EPS1)
        ax.set_ylabel(r"fabric tensor $\phi_{ii}$")
        if k == 0:
            ax.legend(fontsize=8)
        rose_panel(fig.add_subplot(2, n, n + k + 1, projection="polar"), ens, fig_id, name, net, grose,
                   pp.LETTERS[n + k])
    fig.suptitle(f"Fig. {number}  {title}, $\\mu_s$ = {ens.first.mu_s:g}, {label}\n{ens.text()} "
                 f"(solid, shaded); dashed: the global network's mean", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.93))
    pp.save(fig, path, written)


def fig_anisotropy(ens, path, written):
    name, label = ens.first.reference().name, ens.first.reference().label
    nets = ["all", "ns", "s", "sf", "wf", "ns-sf", "ns-wf", "s-sf", "s-wf"]
    fig, ax = plt.subplots(1, 2, figsize=(13, 5.2))
    for i, key in enumerate(("a_c", "a_n")):
        for net in nets:
            draw(ax[i], ens.net_band("fig08", name, net, key), pp.NET_COLOURS[net], pd.NETWORK_LABELS[net],
                 ls="-" if net in ("all", "ns", "sf", "ns-sf") else "--", lw=2.4 if net == "all" else 1.2)
        ax[i].axhline(0, color="k", lw=0.5)
        ax[i].set_xlabel(pp.EPS1)
        ax[i].set_ylabel(f"${key}^k$")
        ax[i].set_title(f"({pp.LETTERS[i]}) " + ("contact normal anisotropy" if key == "a_c"
                                                  else "normal contact force anisotropy") + f" ${key}^k$")
    ax[0].legend(ncol=2, fontsize=8)
    fig.suptitle(f"Fig. 8  Anisotropy of the sub-networks during shear, $\\mu_s$ = {ens.first.mu_s:g}, {label}: "
                 f"{ens.text()}", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.94))
    pp.save(fig, path, written)


def fig_anisotropy_mur(ens, path, written):
    col = pp.mur_colours(ens.first)
    fig, ax = plt.subplots(2, 4, figsize=(16, 7.6), sharex=True)
    for j, net in enumerate(["all", "ns", "sf", "ns-sf"]):
        for i, key in enumerate(("a_c", "a_n")):
            for c in ens.first.cases:
                draw(ax[i, j], ens.net_band("fig09", c.name, net, key), col[c.name], c.label)
            ax[i, j].set_title(f"({pp.LETTERS[4 * i + j]}) ${key}$ of " + pd.NETWORK_LABELS[net])
            ax[i, j].set_ylabel(f"${key}$")
            if i == 1:
                ax[i, j].set_xlabel(pp.EPS1)
    ax[0, 0].legend()
    fig.suptitle(f"Fig. 9  Influence of rolling resistance on the anisotropy indices ($\\mu_s$ = {ens.first.mu_s:g}): "
                 f"{ens.text()}", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    pp.save(fig, path, written)


def fig_stress_strain(ens, path, written):
    col = pp.mur_colours(ens.first)
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.8))
    for c in ens.first.cases:
        draw(ax[0], ens.series_band("fig10", c.name, "q_p"), col[c.name], c.label)
        draw(ax[1], ens.series_band("fig10", c.name, "epsv", 100.0), col[c.name], c.label)
    ax[0].set_ylabel(r"stress ratio $q/p$")
    ax[0].set_title("(a) stress ratio")
    ax[1].set_ylabel(r"volumetric strain $\varepsilon_v$ (%), compression positive")
    ax[1].set_title("(b) volumetric strain (below 0: dilation)")
    ax[1].axhline(0, color="k", lw=0.5)
    for a in ax:
        a.set_xlabel(pp.EPS1)
        a.legend()
    fig.suptitle(f"Fig. 10  Macroscopic stress-strain response ($\\mu_s$ = {ens.first.mu_s:g}): {ens.text()}",
                 fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.93))
    pp.save(fig, path, written)


def fig_xi(ens, path, written):
    nets = ["ns", "sf", "ns-sf"]
    col = pp.mur_colours(ens.first)
    fig, ax = plt.subplots(1, 4, figsize=(17, 4.6))
    for j, net in enumerate(nets):
        for c in ens.first.cases:
            draw(ax[j], ens.net_band("fig11", c.name, net, "xi"), col[c.name], c.label)
        ax[j].set_title(f"({pp.LETTERS[j]}) $\\xi_k$, k = {pd.NETWORK_LABELS[net]}")
        ax[j].set_xlabel(pp.EPS1)
        ax[j].set_ylabel(f"$\\xi_k$ of {net}")
    ax[0].legend()
    murs = [c.mu_r for c in ens.first.cases]
    for net in nets:
        bs = [ens.point_band("fig11", c.name, net, "xi_residual", [x.res_mean(net, "xi") for x in ens.cases(c.name)],
                             c.mu_r) for c in ens.first.cases]
        for c in ens.first.cases:
            ax[3].plot([c.mu_r] * len(ens.runs), [x.res_mean(net, "xi") for x in ens.cases(c.name)], "o", ms=3,
                       color=pp.NET_COLOURS[net], alpha=0.45)
        ax[3].errorbar(murs, [b.mean[0] for b in bs], yerr=[b.half_width[0] for b in bs], fmt="-s", capsize=3,
                       color=pp.NET_COLOURS[net], label=pd.NETWORK_LABELS[net])
    ax[3].set_xlabel(r"rolling resistance coefficient $\mu_r$")
    ax[3].set_ylabel(r"$\xi_k$, mean over the residual state")
    ax[3].set_title("(d) $\\xi_k$ against $\\mu_r$ (points: each realisation)")
    ax[3].legend()
    fig.suptitle(f"Fig. 11  Influence of rolling resistance on the weights $\\xi_k$: {ens.text()}", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.92))
    pp.save(fig, path, written)


def sff_band(ens, name, partition, form="star"):
    """The mean deviation of the SFF prediction of a partition over the realisations (a Band)."""
    return Band([0.0], [[sff_deviation(c, partition, form)[0] for c in ens.cases(name)]])


def fig_sff(ens, path, written):
    col = pp.mur_colours(ens.first)
    fig, ax = plt.subplots(1, 2, figsize=(14, 5.0), gridspec_kw={"width_ratios": [1.2, 1]})
    for c in ens.first.cases:
        draw(ax[0], ens.series_band("fig12", c.name, "q_p"), col[c.name], f"$q/p$, {c.label}")
        qs = [x.sff for x in ens.cases(c.name)]
        b = curve_band([q["eps1"] for q in qs], [q["q_p_star_ns_s_sf_wf"] for q in qs])
        ens.record("fig12", c.name, "ns_s_sf_wf", "q_p_star", b)
        ax[0].errorbar(100 * b.x, b.mean, yerr=b.half_width, fmt="o", ms=3.5, mfc="none", capsize=2,
                       color=col[c.name], label=f"$(q/p)^*$, {c.label}")
    ax[0].set_xlabel(pp.EPS1)
    ax[0].set_ylabel("stress ratio")
    ax[0].set_title("(a) measured $q/p$ (lines, bands), the SFF prediction $(q/p)^*$ of {ns-sf, ns-wf, s-sf, s-wf}\n"
                    "(circles with the band as error bars; weights $\\xi_k$)")
    ax[0].legend(ncol=2, fontsize=8)
    parts = list(pd.PARTITIONS)
    w = 0.8 / len(ens.first.cases)
    x = np.arange(len(parts))
    for i, c in enumerate(ens.first.cases):
        bs = [sff_band(ens, c.name, p) for p in parts]
        for p, b in zip(parts, bs):
            ens.record("fig12", c.name, p, "sff_deviation", b)
        ax[1].bar(x + (i - (len(ens.first.cases) - 1) / 2) * w, [100 * b.mean[0] for b in bs],
                  yerr=[100 * b.half_width[0] for b in bs], capsize=2, width=w, color=col[c.name], label=c.label)
    ax[1].axhline(5, color="k", lw=0.8, ls="--")
    ax[1].set_xticks(x)
    ax[1].set_xticklabels([pd.PARTITION_LABELS[p].replace(", ", ",\n") if len(pd.PARTITIONS[p]) > 2
                           else pd.PARTITION_LABELS[p] for p in parts], fontsize=8)
    ax[1].set_ylabel(r"mean $|(q/p)^* - q/p| \,/\, (q/p)$ over the shear (%)")
    ax[1].set_title("(b) deviation of the SFF prediction, per partition (error bars: the band)")
    ax[1].legend()
    ax[1].grid(axis="x", visible=False)
    fig.suptitle(f"Fig. 12  Validation of the stress-force-fabric relation: {ens.text()}", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.94))
    pp.save(fig, path, written)


def make_figures(ens, outdir):
    figdir = os.path.join(outdir, "figures")
    os.makedirs(figdir, exist_ok=True)
    written = []
    p = lambda name: os.path.join(figdir, name)  # noqa: E731
    fig_consolidation(ens, p("fig02b_consolidation.png"), written)
    pp.fig_force_chains(ens.first, p("fig03_force_chains.png"), written,
                        note=f"one specimen: realisation seed {ens.seeds[0]}, the first of {len(ens.runs)}")
    fig_fabric(ens, ["ns", "s"], 4, "Fabric of the non-sliding and sliding contacts", p("fig04_fabric_ns_s.png"),
               written)
    fig_fabric(ens, ["ns-nr", "ns-r", "s-nr", "s-r"], 5,
               "Fabric of the non-sliding / sliding, non-rolling / rolling contacts",
               p("fig05_fabric_sliding_rolling.png"), written)
    fig_fabric(ens, ["sf", "wf"], 6, "Fabric of the strong and weak contacts", p("fig06_fabric_strong_weak.png"),
               written)
    fig_fabric(ens, ["ns-sf", "ns-wf", "s-sf", "s-wf"], 7, "Fabric of the non-sliding / sliding, strong / weak "
               "contacts", p("fig07_fabric_sliding_strong.png"), written)
    fig_anisotropy(ens, p("fig08_anisotropy_subnetworks.png"), written)
    fig_anisotropy_mur(ens, p("fig09_anisotropy_vs_mur.png"), written)
    fig_stress_strain(ens, p("fig10_stress_strain.png"), written)
    fig_xi(ens, p("fig11_xi_vs_mur.png"), written)
    fig_sff(ens, p("fig12_sff.png"), written)
    ens.write_bands(os.path.join(figdir, BANDS_FILE))
    return written
