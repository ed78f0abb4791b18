#!/usr/bin/python3
"""Plots the fabric analysis of a triaxial run (OUT/<case>/fabric.csv, sff.csv, rose.csv; see
docs/fabric.md) as PNG files in the output directory:

  fabric_evolution.png  a_c, a_n, a_t of the main networks against axial strain, per case
  fabric_vs_mur.png     a_c, a_n and xi of all, ns, sf, ns-sf against mu_r, at the peak of q/p
                        and at the end of shear (needs two cases or more)
  sff.png               (q/p)* of every partition (solid; tensor form dashed; with the exact
                        shares p_k / p dotted) and the measured q/p against axial strain
  rose_<case>.png       rose diagrams of contact normals (planes 1-2 and 2-3) at the end of shear
Rows of a network whose second-order density 1 + a^c:nn is negative in some direction
(min_weight <= 0) are left out of the a_b, a_n, a_t curves (docs/fabric.md).

    /usr/bin/python3 apps/plot_fabric.py out/demo

Needs Debian's python3-numpy and python3-matplotlib (for /usr/bin/python3).
"""
import argparse
import glob
import os
import sys

from fabrica_cases import mu_r_of

try:
    import numpy as np
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError as e:  # pragma: no cover
    sys.exit(f"plot_fabric.py: {e}; install python3-numpy and python3-matplotlib "
             "and run with /usr/bin/python3")

EVOLUTION_NETWORKS = ["all", "ns", "s", "sf", "wf", "ns-sf", "ns-wf", "s-sf", "s-wf"]
MUR_NETWORKS = ["all", "ns", "sf", "ns-sf"]  # the networks of the study's figures 9 and 11
PARTITIONS = ["all", "ns_s", "sf_wf", "nr_r", "ns_s_nr_r", "ns_s_sf_wf"]
ROSE_NETWORKS = ["all", "ns", "s", "sf", "wf"]


def load(path, required):
    d = np.genfromtxt(path, delimiter=",", names=True, dtype=None, encoding="utf-8")
    d = np.atleast_1d(d)
    if d.size == 0 or required not in d.dtype.names:
        sys.exit(f"plot_fabric.py: {path}: no rows or not a Fabrica fabric file")
    d = d[d["stage"] == "shear"]
    if "min_weight" in d.dtype.names:
        # Rows where the second-order density 1 + a^c:nn of the network is negative in some
        # direction: the weighted tensors (a_b, a_n, a_t) are not meaningful there
        # (docs/fabric.md); they are not plotted.
        bad = (d["nonpositive_weights"] > 0) | ~(d["min_weight"] > 0)
        for k in ("a_b", "a_n", "a_t"):
            d[k][bad] = np.nan
    return d


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("outdir", help="output directory of a triaxial run")
    a = ap.parse_args()
    dirs = sorted(os.path.dirname(f) for f in glob.glob(os.path.join(a.outdir, "*", "fabric.csv")))
    if not dirs:
        sys.exit(f"plot_fabric.py: no */fabric.csv under {a.outdir}")
    cases = [os.path.basename(d) for d in dirs]
    fab = {c: load(os.path.join(d, "fabric.csv"), "a_c") for c, d in zip(cases, dirs)}
    sff = {c: load(os.path.join(d, "sff.csv"), "q_p") for c, d in zip(cases, dirs)}
    written = []

    # Anisotropy indices against axial strain.
    fig, ax = plt.subplots(len(cases), 3, figsize=(15, 3.6 * len(cases)), squeeze=False)
    for row, c in enumerate(cases):
        d = fab[c]
        for col, key in enumerate(["a_c", "a_n", "a_t"]):
            for net in EVOLUTION_NETWORKS:
                s = d[d["network"] == net]
                if s.size and np.isfinite(s[key]).any():
                    ax[row, col].plot(s["eps1"], s[key], label=net, lw=2.0 if net == "all" else 1.0)
            ax[row, col].set_title(f"{c}: {key}")
            ax[row, col].set_xlabel("axial strain eps_1")
            ax[row, col].axhline(0, color="k", lw=0.5)
        ax[row, 0].legend(fontsize=7, ncol=2)
    fig.tight_layout()
    written.append(os.path.join(a.outdir, "fabric_evolution.png"))
    fig.savefig(written[-1], dpi=110)
    plt.close(fig)

    # Against mu_r, at the peak of q/p and at the end.
    order = sorted((mu_r_of(c), c) for c in cases if np.isfinite(mu_r_of(c)))
    if len(order) >= 2:
        fig, ax = plt.subplots(1, 3, figsize=(15, 4.2))
        murs = [m for m, _ in order]
        for net in MUR_NETWORKS:
            for when, style in (("peak", "-o"), ("end", "--s")):
                vals = {k: [] for k in ("a_c", "a_n", "xi")}
                for _, c in order:
                    q = sff[c]
                    step = q["step"][int(np.argmax(q["q_p"]))] if when == "peak" else q["step"][-1]
                    s = fab[c][(fab[c]["network"] == net) & (fab[c]["step"] == step)]
                    for k in vals:
                        vals[k].append(s[k][0] if s.size else np.nan)
                for i, k in enumerate(("a_c", "a_n", "xi")):
                    ax[i].plot(murs, vals[k], style, label=f"{net} ({when})", ms=4)
        for i, k in enumerate(("a_c", "a_n", "xi")):
            ax[i].set_xlabel("mu_r")
            ax[i].set_ylabel(k)
        ax[0].legend(fontsize=7, ncol=2)
        fig.tight_layout()
        written.append(os.path.join(a.outdir, "fabric_vs_mur.png"))
        fig.savefig(written[-1], dpi=110)
        plt.close(fig)

    # Stress-force-fabric check.
    fig, ax = plt.subplots(1, len(cases), figsize=(6 * len(cases), 4.2), squeeze=False)
    for i, c in enumerate(cases):
        q = sff[c]
        ax[0, i].plot(q["eps1"], q["q_p"], "k", lw=2.5, label="measured q/p")
        for p in PARTITIONS:
            line, = ax[0, i].plot(q["eps1"], q["q_p_star_" + p], lw=1.0, label=f"(q/p)* {p}")
            if "q_p_tensor_" + p in q.dtype.names:  # the tensor form (docs/fabric.md), dashed
                ax[0, i].plot(q["eps1"], q["q_p_tensor_" + p], "--", lw=0.8, color=line.get_color())
            if "q_p_exact_" + p in q.dtype.names and p != "all":  # weights p_k / p, dotted
                ax[0, i].plot(q["eps1"], q["q_p_exact_" + p], ":", lw=1.0, color=line.get_color())
        ax[0, i].set_title(f"{c} (dashed: tensor form; dotted: exact shares p_k/p)")
        ax[0, i].set_xlabel("axial strain eps_1")
        ax[0, i].set_ylabel("q/p")
        ax[0, i].legend(fontsize=7)
    fig.tight_layout()
    written.append(os.path.join(a.outdir, "sff.png"))
    fig.savefig(written[-1], dpi=110)
    plt.close(fig)

    # Rose diagrams at the last analysed instant of the shear stage.
    for c, d in zip(cases, dirs):
        r = load(os.path.join(d, "rose.csv"), "plane")
        if r.size == 0:
            continue
        r = r[r["step"] == r["step"][-1]]
        bins = [n for n in r.dtype.names if n.startswith("bin")]
        nb = len(bins)
        width = np.pi / nb
        theta = (np.arange(nb) + 0.5) * width
        fig, ax = plt.subplots(2, len(ROSE_NETWORKS), subplot_kw={"projection": "polar"},
                               figsize=(3.2 * len(ROSE_NETWORKS), 6.6), squeeze=False)
        for j, net in enumerate(ROSE_NETWORKS):
            for i, plane in enumerate(("12", "23")):
                s = r[(r["network"] == net) & (r["plane"].astype(str) == plane)]
                axp = ax[i, j]
                if s.size:
                    counts = np.array([s[b][0] for b in bins], dtype=float)
                    total = counts.sum()
                    frac = counts / total if total > 0 else counts
                    # n and -n are one direction: the same counts on the opposite side.
                    axp.bar(np.concatenate([theta, theta + np.pi]), np.concatenate([frac, frac]),
                            width=width, bottom=0.0, edgecolor="k", linewidth=0.3)
                axp.set_title(f"{net}, plane {plane[0]}-{plane[1]}", fontsize=9)
                axp.set_xticks(np.radians([0, 90, 180, 270]))
                axp.set_xticklabels([f"axis {plane[0]}", f"axis {plane[1]}", "", ""], fontsize=7)
                axp.tick_params(labelsize=6)
        fig.suptitle(f"{c}: contact normals at eps_1 = {r['eps1'][-1]:.3f} (fraction per bin)")
        fig.tight_layout()
        written.append(os.path.join(a.outdir, f"rose_{c}.png"))
        fig.savefig(written[-1], dpi=110)
        plt.close(fig)
    print("plots written: " + ", ".join(written))


if __name__ == "__main__":
    main()
