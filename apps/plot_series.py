#!/usr/bin/python3
"""Plots a Fabrica series (series.csv written by `fabrica run`): stress, coordination number
and energies against time, as PNG files.

    /usr/bin/python3 apps/plot_series.py out/demo/series.csv -o out/demo

Needs Debian's python3-numpy and python3-matplotlib (for /usr/bin/python3).
"""
import argparse
import os
import sys

try:
    import numpy as np
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError as e:  # pragma: no cover
    sys.exit(f"plot_series.py: {e}; install python3-numpy and python3-matplotlib "
             "and run with /usr/bin/python3")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("series", help="series.csv from fabrica run")
    ap.add_argument("-o", "--output", default=".", help="directory for the PNG files")
    a = ap.parse_args()
    try:
        d = np.genfromtxt(a.series, delimiter=",", names=True)
    except OSError as e:
        sys.exit(f"plot_series.py: {a.series}: {e}")
    if d.size == 0 or "p" not in d.dtype.names:
        sys.exit(f"plot_series.py: {a.series}: no rows or not a Fabrica series")
    d = np.atleast_1d(d)
    os.makedirs(a.output, exist_ok=True)
    t = d["time"]

    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    for k in ("s11", "s22", "s33", "p", "q"):
        ax[0].plot(t, d[k] / 1e3, label=k)
    ax[0].set_xlabel("time [s]")
    ax[0].set_ylabel("stress [kPa] (compression positive)")
    ax[0].legend()
    ax[1].plot(t, d["Z"], label="Z = 2C/N")
    ax[1].set_xlabel("time [s]")
    ax[1].set_ylabel("coordination number")
    ax[1].legend()
    fig.tight_layout()
    f1 = os.path.join(a.output, "stress.png")
    fig.savefig(f1, dpi=120)

    fig, ax = plt.subplots(figsize=(6, 4))
    for k in ("kinetic", "e_normal", "e_shear", "e_rolling", "diss_friction", "diss_rolling",
              "diss_viscous", "diss_local"):
        ax.plot(t, d[k], label=k)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("energy [J]")
    ax.set_yscale("symlog", linthresh=1e-6)
    ax.legend(fontsize=7)
    fig.tight_layout()
    f2 = os.path.join(a.output, "energy.png")
    fig.savefig(f2, dpi=120)
    print(f"plots written: {f1}, {f2}")


if __name__ == "__main__":
    main()
