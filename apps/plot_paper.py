#!/usr/bin/python3
"""The reference study's figures 3-12 from a triaxial run, and the report page.

    /usr/bin/python3 apps/plot_paper.py OUT [--no-report]

writes OUT/figures/ (docs/fabric.md, "Figures of the study", says what each shows):
  fig03_force_chains.png            force chains of the global, non-sliding, sliding and strong
                                    networks at the end of shear (a slab normal to axis 3)
  fig04_fabric_ns_s.png             phi_11, phi_22, phi_33 of ns and s against eps_1 (global
  fig05_fabric_sliding_rolling.png  dashed) and their rose diagrams at the end; the same for
  fig06_fabric_strong_weak.png      {ns-nr, ns-r, s-nr, s-r}, {sf, wf} and
  fig07_fabric_sliding_strong.png   {ns-sf, ns-wf, s-sf, s-wf}
  fig08_anisotropy_subnetworks.png  a_c and a_n of the sub-networks against eps_1
  fig09_anisotropy_vs_mur.png       a_c and a_n of all, ns, sf, ns-sf for every mu_r
  fig10_stress_strain.png           q/p and eps_v against eps_1 for every mu_r
  fig11_xi_vs_mur.png               xi of ns, sf, ns-sf against eps_1 and against mu_r
  fig12_sff.png                     (q/p)* of {ns-sf, ns-wf, s-sf, s-wf} against the measured
                                    q/p, and the mean deviation of every partition (with the
                                    study's weights xi and with the exact shares p_k / p)
and OUT/report.html (apps/paper_report.py) unless --no-report. Figures 3-8 show the case whose
mu_r is nearest the study's 0.05 (among mu_r > 0). On the output of an ensemble (OUT/seed_<s>/
each a triaxial run) the same figures over the realisations, each curve the mean and its 95 %
band, with fig02b_consolidation.png (the study's figure 2(b)) and the bands' numbers in
figures/ensemble_bands.csv (apps/paper_ensemble.py), the findings decided over the realisations
(apps/ensemble_findings.py: OUT/findings.csv, figures/ensemble_trends.png) and the ensemble's
report page. Needs /usr/bin/python3 with numpy,
matplotlib and h5py (Debian's python3-numpy, python3-matplotlib, python3-h5py).
"""
import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

try:
    import numpy as np
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection
    import paper_data as pd
    from paper_findings import sff_deviation
except ImportError as e:  # pragma: no cover
    sys.exit(f"plot_paper.py: {e}; install python3-numpy, python3-matplotlib and python3-h5py "
             "and run with /usr/bin/python3")

PHI_COLOURS = {"phi11": "#1f5fbf", "phi22": "#d1495b", "phi33": "#2a9d3f"}
PHI_LABELS = {"phi11": r"$\phi_{11}$", "phi22": r"$\phi_{22}$", "phi33": r"$\phi_{33}$"}
NET_COLOURS = {"all": "k", "ns": "#1f5fbf", "s": "#e07b00", "sf": "#c0262d", "wf": "#7f7f7f",
               "ns-sf": "#6a1b9a", "ns-wf": "#2a9d3f", "s-sf": "#b8860b", "s-wf": "#17becf",
               "r": "#8c564b", "nr": "#e377c2", "ns-nr": "#1f5fbf", "ns-r": "#2a9d3f",
               "s-nr": "#c0262d", "s-r": "#e07b00"}
EPS1 = r"axial strain $\varepsilon_1$ (%)"
LETTERS = "abcdefghijkl"

plt.rcParams.update({"font.size": 10, "axes.titlesize": 10.5, "legend.fontsize": 8.5,
                     "axes.grid": True, "grid.alpha": 0.3, "savefig.dpi": 130})


def mur_colours(run):
    cmap = plt.get_cmap("viridis")
    n = len(run.cases)
    return {c.name: cmap(0.85 * i / max(n - 1, 1)) for i, c in enumerate(run.cases)}


def save(fig, path, written):
    fig.savefig(path, bbox_inches="tight")
    plt.close(fig)
    written.append(path)


def fig_force_chains(run, path, written, note=""):
    """Force chains of the reference case at the end of shear; note: a line added to the title
    (an ensemble's figure names the realisation drawn)."""
    case = run.reference()
    c = run.last_contacts(case)
    L = c.info.cell_lengths
    # A slab through the middle of the cell, normal to axis 3, one third of the cell thick:
    # the contacts whose midpoint lies in it, projected on the 1-2 plane (axis 1 upwards).
    mid = c.ends.mean(axis=1)
    x3 = np.mod(mid[:, 2], L[2])
    slab = np.abs(x3 - L[2] / 2) <= L[2] / 6
    fmax = c.fn[slab].max() if slab.any() else 1.0
    every = c.ends[slab][:, :, [1, 0]].reshape(-1, 2)
    lo, hi = every.min(axis=0, initial=0.0), every.max(axis=0, initial=0.0)
    panels = [("all", "global network"), ("ns", "non-sliding (ns)"), ("s", "sliding (s)"),
              ("sf", "strong (sf)")]
    fig, ax = plt.subplots(1, 4, figsize=(15, 6.4), sharey=True)
    for k, (net, title) in enumerate(panels):
        m = c.network(net) & slab
        segs = c.ends[m][:, :, [1, 0]]  # (x2, x1)
        lw = 0.25 + 4.0 * c.fn[m] / fmax
        ax[k].add_collection(LineCollection(segs, linewidths=lw, colors=NET_COLOURS[net],
                                            capstyle="round"))
        ax[k].plot([0, L[1], L[1], 0, 0], [0, 0, L[0], L[0], 0], color="0.6", lw=0.8)
        ax[k].set_aspect("equal")
        pad = 0.03 * L[1]  # the same limits in every panel: those of the global network's slab
        ax[k].set_xlim(min(lo[0], 0) - pad, max(hi[0], L[1]) + pad)
        ax[k].set_ylim(min(lo[1], 0) - pad, max(hi[1], L[0]) + pad)
        ax[k].set_title(f"({LETTERS[k]}) {title}\n{int(m.sum())} of {int(c.network(net).sum())} contacts in the slab"
                        if net != "all" else f"({LETTERS[k]}) {title}\n{int(m.sum())} of {len(c)} contacts in the slab")
        ax[k].set_xlabel(r"$x_2$ (m)")
        ax[k].grid(False)
    ax[0].set_ylabel(r"$x_1$ (m), loading axis")
    eps1 = 100 * c.info.strain[0]
    fig.suptitle(f"Fig. 3  Force chains at the end of shear ($\\varepsilon_1$ = {eps1:.1f} %), "
                 f"$\\mu_s$ = {run.mu_s:g}, {case.label}\ncontacts with their midpoint in the middle third of the cell "
                 f"along axis 3, projected on the 1-2 plane; line width proportional to $f_n$ "
                 f"(largest {fmax:.3g} N)" + (f"\n{note}" if note else ""), fontsize=10.5)
    fig.tight_layout(rect=(0, 0, 1, 0.91 if note else 0.93))
    save(fig, path, written)


def rose_panel(ax, case, network, letter):
    r = case.rose
    last = r["step"] == r["step"][-1]
    bins = [n for n in r.dtype.names if n.startswith("bin")]
    merge = 2 if len(bins) % 2 == 0 and len(bins) >= 24 else 1  # 36 bins of 5 degrees -> 18 of 10
    nb = len(bins) // merge
    width = np.pi / nb
    theta = (np.arange(nb) + 0.5) * width
    ax.set_theta_zero_location("N")  # axis 1 upwards
    ax.set_theta_direction(-1)       # axis 2 to the right

    def counts(net):
        s = r[last & (r["network"] == net) & (r["plane"].astype(str) == "12")]
        if not s.size:
            return None
        v = np.array([s[b][0] for b in bins], dtype=float).reshape(nb, merge).sum(axis=1)
        return v / v.sum() if v.sum() > 0 else None

    f = counts(network)
    if f is not None:
        ax.bar(np.concatenate([theta, theta + np.pi]), np.concatenate([f, f]), width=width,
               color=NET_COLOURS.get(network, "C0"), alpha=0.75, edgecolor="k", linewidth=0.3)
    g = counts("all")
    if g is not None and network != "all":
        t = np.concatenate([theta, theta + np.pi, theta[:1]])
        ax.plot(t, np.concatenate([g, g, g[:1]]), "k--", lw=0.9, label="global")
    ax.set_xticks(np.radians([0, 90, 180, 270]))
    ax.set_xticklabels(["axis 1", "axis 2", "", ""], fontsize=8)
    ax.tick_params(labelsize=7)
    ax.set_title(f"({letter}) {pd.NETWORK_LABELS[network]}: contact normals\n"
                 f"at $\\varepsilon_1$ = {100 * r['eps1'][-1]:.1f} %, plane 1-2 (share per bin)", fontsize=9.5)
    if f is None:
        ax.text(0.5, 0.5, "no contacts", transform=ax.transAxes, ha="center")


def fig_fabric(run, networks, number, title, path, written):
    case = run.reference()
    n = len(networks)
    fig = plt.figure(figsize=(4.6 * n, 9.0))
    glob_rows = case.net("all")
    for k, net in enumerate(networks):
        ax = fig.add_subplot(2, n, k + 1)
        s = case.net(net)
        empty = s.size == 0 or not np.isfinite(s["phi11"]).any()
        for key in ("phi11", "phi22", "phi33"):
            if not empty:
                ax.plot(100 * s["eps1"], s[key], color=PHI_COLOURS[key], lw=1.6,
                        label=f"{PHI_LABELS[key]} of the network")
            ax.plot(100 * glob_rows["eps1"], glob_rows[key], "--", color=PHI_COLOURS[key], lw=1.0,
                    label=f"{PHI_LABELS[key]} global")
        ax.axhline(1 / 3, color="0.4", lw=0.6, ls=":")
        if empty:
            why = " (with $\\mu_r$ = 0 every contact rolls)" if net in ("nr", "ns-nr", "s-nr") else ""
            ax.text(0.5, 0.5, f"network empty{why}", transform=ax.transAxes, ha="center")
        share = f"\n{100 * s['zeta'][-1]:.0f} % of the contacts at the end" if not empty else "\n"
        ax.set_title(f"({LETTERS[k]}) {pd.NETWORK_LABELS[net]}{share}")
        ax.set_xlabel(EPS1)
        ax.set_ylabel(r"fabric tensor $\phi_{ii}$")
        top = np.nanmax([s[k].max() for k in ("phi11", "phi22", "phi33")]) if not empty else 0.5
        ax.set_ylim(0.15, max(0.6, top + 0.03))
        if k == 0:
            handles, labels = ax.get_legend_handles_labels()
        axr = fig.add_subplot(2, n, n + k + 1, projection="polar")
        rose_panel(axr, case, net, LETTERS[n + k])
        if k == 0:
            h, lab = axr.get_legend_handles_labels()
            handles, labels = handles + h, labels + ["global (rose)"]
    fig.suptitle(f"Fig. {number}  {title}, $\\mu_s$ = {run.mu_s:g}, {case.label}\nsolid: the network, dashed: the "
                 f"global network; rose diagrams at the end of shear (dashed outline: global)", fontsize=11)
    # one row of 7 (4 networks) or 2 rows filled column by column (network above global)
    order = [0, 2, 4, 1, 3, 5, 6] if len(handles) == 7 and n >= 4 else range(len(handles))
    fig.legend([handles[i] for i in order], [labels[i] for i in order], loc="upper center",
               ncol=7 if n >= 4 else 4, bbox_to_anchor=(0.5, 0.945), fontsize=9, frameon=False)
    fig.tight_layout(rect=(0, 0, 1, 0.92 if n >= 4 else 0.89))
    save(fig, path, written)


def fig_anisotropy(run, path, written):
    case = run.reference()
    nets = ["all", "ns", "s", "sf", "wf", "ns-sf", "ns-wf", "s-sf", "s-wf"]
    fig, ax = plt.subplots(1, 2, figsize=(13, 5.2))
    for i, (key, sym) in enumerate((("a_c", "a_c^k"), ("a_n", "a_n^k"))):
        for net in nets:
            s = case.net(net)
            if s.size:
                ax[i].plot(100 * s["eps1"], s[key], color=NET_COLOURS[net], lw=2.4 if net == "all" else 1.2,
                           ls="-" if net in ("all", "ns", "sf", "ns-sf") else "--", label=pd.NETWORK_LABELS[net])
        ax[i].axhline(0, color="k", lw=0.5)
        ax[i].set_xlabel(EPS1)
        ax[i].set_ylabel(f"${sym}$")
        name = "contact normal anisotropy" if key == "a_c" else "normal contact force anisotropy"
        ax[i].set_title(f"({LETTERS[i]}) {name} ${sym}$")
    ax[0].legend(ncol=2, fontsize=8)
    fig.suptitle(f"Fig. 8  Anisotropy of the sub-networks during shear, $\\mu_s$ = {run.mu_s:g}, {case.label} "
                 f"(a_n left out where the network's density 1 + a_c:nn is not positive)", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.94))
    save(fig, path, written)


def fig_anisotropy_mur(run, path, written):
    nets = ["all", "ns", "sf", "ns-sf"]
    col = mur_colours(run)
    fig, ax = plt.subplots(2, 4, figsize=(16, 7.6), sharex=True)
    for j, net in enumerate(nets):
        for i, (key, sym) in enumerate((("a_c", "a_c"), ("a_n", "a_n"))):
            for c in run.cases:
                s = c.net(net)
                ax[i, j].plot(100 * s["eps1"], s[key], color=col[c.name], lw=1.4, label=c.label)
            sup = "" if net == "all" else "^k"
            ax[i, j].set_title(f"({LETTERS[4 * i + j]}) ${sym}{sup}$, k = {pd.NETWORK_LABELS[net]}"
                               if net != "all" else f"({LETTERS[4 * i + j]}) ${sym}$, global network")
            ax[i, j].set_ylabel(f"${sym}$ of {net}" if net != "all" else f"${sym}$")
            if i == 1:
                ax[i, j].set_xlabel(EPS1)
    ax[0, 0].legend()
    fig.suptitle("Fig. 9  Influence of rolling resistance on the anisotropy indices of the global, ns, sf and "
                 f"ns-sf networks ($\\mu_s$ = {run.mu_s:g})", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    save(fig, path, written)


def fig_stress_strain(run, path, written):
    col = mur_colours(run)
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.8))
    for c in run.cases:
        s = c.shear()
        ax[0].plot(100 * s["eps1"], s["q_p"], color=col[c.name], lw=1.5, label=c.label)
        ax[1].plot(100 * s["eps1"], 100 * s["epsv"], color=col[c.name], lw=1.5, label=c.label)
    ax[0].set_ylabel(r"stress ratio $q/p$")
    ax[0].set_title("(a) stress ratio")
    ax[1].set_ylabel(r"volumetric strain $\varepsilon_v$ (%), compression positive")
    ax[1].set_title("(b) volumetric strain (below 0: dilation)")
    ax[1].axhline(0, color="k", lw=0.5)
    for a in ax:
        a.set_xlabel(EPS1)
        a.legend()
    fig.suptitle("Fig. 10  Macroscopic stress-strain response for different rolling resistance coefficients "
                 f"($\\mu_s$ = {run.mu_s:g})", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.93))
    save(fig, path, written)


def fig_xi(run, path, written):
    nets = ["ns", "sf", "ns-sf"]
    col = mur_colours(run)
    fig, ax = plt.subplots(1, 4, figsize=(17, 4.6))
    for j, net in enumerate(nets):
        for c in run.cases:
            s = c.net(net)
            ax[j].plot(100 * s["eps1"], s["xi"], color=col[c.name], lw=1.4, label=c.label)
        ax[j].set_title(f"({LETTERS[j]}) $\\xi_k$, k = {pd.NETWORK_LABELS[net]}")
        ax[j].set_xlabel(EPS1)
        ax[j].set_ylabel(f"$\\xi_k$ of {net}")
    ax[0].legend()
    murs = [c.mu_r for c in run.cases]
    for net in nets:
        ax[3].plot(murs, [c.res_mean(net, "xi") for c in run.cases], "-o", color=NET_COLOURS[net],
                   label=pd.NETWORK_LABELS[net])
    ax[3].set_xlabel(r"rolling resistance coefficient $\mu_r$")
    ax[3].set_ylabel(r"$\xi_k$, mean over the residual state")
    ax[3].set_title(f"(d) $\\xi_k$ against $\\mu_r$ ($\\varepsilon_1 \\geq$ {pd.RESIDUAL_FROM:g} × the final strain)")
    ax[3].legend()
    fig.suptitle("Fig. 11  Influence of rolling resistance on the weights $\\xi_k$ = $\\zeta_k \\gamma_k$ "
                 "(share of the contacts × relative mean normal force)", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.92))
    save(fig, path, written)


def fig_sff(run, path, written):
    col = mur_colours(run)
    fig, ax = plt.subplots(1, 2, figsize=(14, 5.0), gridspec_kw={"width_ratios": [1.2, 1]})
    for c in run.cases:
        q = c.sff
        ax[0].plot(100 * q["eps1"], q["q_p"], color=col[c.name], lw=1.6, label=f"$q/p$, {c.label}")
        ax[0].plot(100 * q["eps1"], q["q_p_star_ns_s_sf_wf"], "o", ms=3.5, mfc="none", color=col[c.name],
                   label=f"$(q/p)^*$, {c.label}")
        if "q_p_exact_ns_s_sf_wf" in q.dtype.names:  # weighted by the exact shares p_k / p
            ax[0].plot(100 * q["eps1"], q["q_p_exact_ns_s_sf_wf"], "+", ms=4, color=col[c.name],
                       label=f"$(q/p)^*_{{exact}}$, {c.label}")
    ax[0].set_xlabel(EPS1)
    ax[0].set_ylabel(r"stress ratio")
    ax[0].set_title("(a) measured $q/p$ (lines), the SFF prediction $(q/p)^*$ of {ns-sf, ns-wf, s-sf, s-wf}\n"
                    "(circles: weights $\\xi_k$; crosses: the exact shares $p_k/p$)")
    ax[0].legend(ncol=2, fontsize=8)
    parts = list(pd.PARTITIONS)
    w = 0.8 / len(run.cases)
    x = np.arange(len(parts))
    for i, c in enumerate(run.cases):
        ax[1].bar(x + (i - (len(run.cases) - 1) / 2) * w,
                  [100 * sff_deviation(c, p)[0] for p in parts], width=w, color=col[c.name], label=c.label)
        exact = [100 * sff_deviation(c, p, "exact")[0] for p in parts]
        if all(np.isfinite(exact)):  # the exact form: outlined bars over the study's
            ax[1].bar(x + (i - (len(run.cases) - 1) / 2) * w, exact, width=0.6 * w, fill=False,
                      edgecolor="k", lw=0.8, label="exact shares" if i == 0 else None)
    ax[1].axhline(5, color="k", lw=0.8, ls="--")
    ax[1].text(len(parts) - 0.5, 5.3, "5 %", ha="right", fontsize=8)
    ax[1].set_xticks(x)
    ax[1].set_xticklabels([pd.PARTITION_LABELS[p].replace(", ", ",\n") if len(pd.PARTITIONS[p]) > 2
                           else pd.PARTITION_LABELS[p] for p in parts], fontsize=8)
    ax[1].set_ylabel(r"mean $|(q/p)^* - q/p| \,/\, (q/p)$ over the shear (%)")
    ax[1].set_title("(b) deviation of the SFF prediction, per partition")
    ax[1].legend()
    ax[1].grid(axis="x", visible=False)
    fig.suptitle("Fig. 12  Validation of the stress-force-fabric relation (the spec's scalar form, "
                 "docs/fabric.md)", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.94))
    save(fig, path, written)


def make_figures(run, outdir):
    figdir = os.path.join(outdir, "figures")
    os.makedirs(figdir, exist_ok=True)
    written = []
    p = lambda name: os.path.join(figdir, name)  # noqa: E731
    fig_force_chains(run, p("fig03_force_chains.png"), written)
    fig_fabric(run, ["ns", "s"], 4, "Fabric of the non-sliding and sliding contacts",
               p("fig04_fabric_ns_s.png"), written)
    fig_fabric(run, ["ns-nr", "ns-r", "s-nr", "s-r"], 5,
               "Fabric of the non-sliding / sliding, non-rolling / rolling contacts",
               p("fig05_fabric_sliding_rolling.png"), written)
    fig_fabric(run, ["sf", "wf"], 6, "Fabric of the strong and weak contacts",
               p("fig06_fabric_strong_weak.png"), written)
    fig_fabric(run, ["ns-sf", "ns-wf", "s-sf", "s-wf"], 7,
               "Fabric of the non-sliding / sliding, strong / weak contacts",
               p("fig07_fabric_sliding_strong.png"), written)
    fig_anisotropy(run, p("fig08_anisotropy_subnetworks.png"), written)
    fig_anisotropy_mur(run, p("fig09_anisotropy_vs_mur.png"), written)
    fig_stress_strain(run, p("fig10_stress_strain.png"), written)
    fig_xi(run, p("fig11_xi_vs_mur.png"), written)
    fig_sff(run, p("fig12_sff.png"), written)
    return written


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("outdir", help="output directory of a triaxial run (fabrica run with [triaxial]), "
                    "or of an ensemble of realisations (OUT/seed_<s>/)")
    ap.add_argument("--no-report", action="store_true", help="write the figures only, not report.html")
    a = ap.parse_args()
    import ensemble_findings
    if ensemble_findings.realisations(a.outdir):
        return ensemble(a.outdir, a.no_report)
    run = pd.load(a.outdir)
    written = make_figures(run, a.outdir)
    print("figures written: " + ", ".join(os.path.basename(w) for w in written) + f" in {a.outdir}/figures")
    if not a.no_report:
        import paper_report
        print(f"report written: {paper_report.write(run, a.outdir, written)}")


def ensemble(out, no_report):
    """An ensemble's output: the figures over its realisations (apps/paper_ensemble.py), its
    findings (apps/ensemble_findings.py: OUT/findings.csv, ensemble_trends.png) and the report."""
    import ensemble_findings
    import paper_ensemble
    ens = paper_ensemble.Ensemble(out)
    written = paper_ensemble.make_figures(ens, out)
    rows = ensemble_findings.decide(out, ens.runs)
    ensemble_findings.write(out, rows)
    trends = [w for w in ensemble_findings.figures(out, ens.runs) if w.endswith("ensemble_trends.png")]
    print("figures written: " + ", ".join(os.path.basename(w) for w in written + trends)
          + f" in {out}/figures; bands in {out}/figures/{paper_ensemble.BANDS_FILE}")
    print(f"findings written: {os.path.join(out, 'findings.csv')}")
    if not no_report:
        import paper_report
        print(f"report written: {paper_report.write_ensemble(ens, out, written + trends)}")


if __name__ == "__main__":
    main()
