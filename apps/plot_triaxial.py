#!/usr/bin/python3
"""Plots the output of a triaxial run (`fabrica run` with [triaxial]): q/p and volumetric
strain against axial strain for every case, the lateral stresses, and the energy balance, as
PNG files in the output directory.

    /usr/bin/python3 apps/plot_triaxial.py out/demo

Needs Debian's python3-numpy and python3-matplotlib (for /usr/bin/python3).
"""
import argparse
import glob
import os
import sys

try:
    import numpy as np
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError as e:  # pragma: no cover
    sys.exit(f"plot_triaxial.py: {e}; install python3-numpy and python3-matplotlib "
             "and run with /usr/bin/python3")


def load(path):
    d = np.genfromtxt(path, delimiter=",", names=True, dtype=None, encoding="utf-8")
    if d.size == 0 or "q_p" not in d.dtype.names:
        sys.exit(f"plot_triaxial.py: {path}: no rows or not a Fabrica triaxial series")
    return np.atleast_1d(d)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("outdir", help="output directory of a triaxial run")
    a = ap.parse_args()
    files = sorted(glob.glob(os.path.join(a.outdir, "*", "series.csv")))
    if not files:
        sys.exit(f"plot_triaxial.py: no */series.csv under {a.outdir}")
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.2))
    for f in files:
        d = load(f)
        s = d[d["stage"] == "shear"]
        name = os.path.basename(os.path.dirname(f))
        ax[0].plot(s["eps1"], s["q_p"], label=name)
        ax[1].plot(s["eps1"], s["epsv"], label=name)
        ax[2].plot(s["eps1"], s["s22"] / 1e3, label=f"{name} s22")
        ax[2].plot(s["eps1"], s["s33"] / 1e3, "--", label=f"{name} s33")
    ax[0].set_ylabel("q/p")
    ax[1].set_ylabel("volumetric strain (compression positive)")
    ax[2].set_ylabel("lateral stress [kPa]")
    for x in ax:
        x.set_xlabel("axial strain eps_1")
        x.legend(fontsize=7)
    fig.tight_layout()
    f1 = os.path.join(a.outdir, "shear.png")
    fig.savefig(f1, dpi=120)

    fig, ax = plt.subplots(figsize=(6, 4))
    for f in files:
        d = load(f)
        ax.plot(d["step"], 100 * d["energy_error"], label=os.path.basename(os.path.dirname(f)))
    ax.set_xlabel("step")
    ax.set_ylabel("energy balance error [% of boundary work]")
    ax.legend(fontsize=7)
    fig.tight_layout()
    f2 = os.path.join(a.outdir, "energy.png")
    fig.savefig(f2, dpi=120)
    print(f"plots written: {f1}, {f2}")


if __name__ == "__main__":
    main()
