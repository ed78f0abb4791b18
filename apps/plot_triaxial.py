#!/usr/bin/python3
"""Plots the output of triaxial runs (`fabrica run` with [triaxial]): q/p and volumetric
strain against axial strain for every case, the lateral stresses, and the energy balance, as
PNG files (shear.png, energy.png).

    /usr/bin/python3 apps/plot_triaxial.py out/demo [out/other ...] [-o DIR]

Each run directory is read from its run.h5 (the series tables, docs/output.md) when it has one
and h5py is installed, otherwise from its CSV files (*/series.csv). The plots go into the run
directory when one is given, else into -o DIR (default: the current directory).
Needs Debian's python3-numpy and python3-matplotlib, and python3-h5py for run.h5 (for
/usr/bin/python3).
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


def load_h5(path):
    """{case: structured array} of the shear cases of a run.h5 (every series with a q_p column
    except the consolidation), read through apps/fabrica_h5.py."""
    import fabrica_h5
    out = {}
    try:
        run = fabrica_h5.RunFile(path)
        for case in run.series_cases():
            if case == "consolidation":
                continue
            s = run.series(case)
            if "q_p" not in s or len(s) == 0:
                continue
            cols = ["step"] + (["stage"] if s.stage else []) + s.columns
            d = np.zeros(len(s), dtype=[(c, "U16" if c == "stage" else "f8") for c in cols])
            d["step"] = s.step
            if s.stage:
                d["stage"] = s.stage
            for c in s.columns:
                d[c] = s[c]
            out[case] = d
    except fabrica_h5.FabricaFileError as e:
        sys.exit(f"plot_triaxial.py: {e}")
    if not out:
        sys.exit(f"plot_triaxial.py: {path}: no triaxial series")
    return out


def have_h5py():
    try:
        import h5py  # noqa: F401
        return True
    except ImportError:
        return False


def load_run(outdir):
    """{case: rows} of one run directory, from run.h5 if possible, else from the CSV files."""
    h5 = os.path.join(outdir, "run.h5")
    if os.path.exists(h5) and have_h5py():
        return load_h5(h5)
    files = sorted(glob.glob(os.path.join(outdir, "*", "series.csv")))
    if not files:
        hint = " (run.h5 present but python3-h5py missing)" if os.path.exists(h5) else ""
        sys.exit(f"plot_triaxial.py: no run.h5 or */series.csv under {outdir}{hint}")
    return {os.path.basename(os.path.dirname(f)): load(f) for f in files}


def load(path):
    d = np.genfromtxt(path, delimiter=",", names=True, dtype=None, encoding="utf-8")
    if d.size == 0 or "q_p" not in d.dtype.names:
        sys.exit(f"plot_triaxial.py: {path}: no rows or not a Fabrica triaxial series")
    return np.atleast_1d(d)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("outdir", nargs="+", help="output directories of triaxial runs")
    ap.add_argument("-o", "--out", help="directory of the PNG files")
    a = ap.parse_args()
    runs = {}
    for o in a.outdir:
        prefix = "" if len(a.outdir) == 1 else os.path.basename(os.path.normpath(o)) + ": "
        for case, d in load_run(o).items():
            runs[prefix + case] = d
    dest = a.out or (a.outdir[0] if len(a.outdir) == 1 else ".")
    os.makedirs(dest, exist_ok=True)
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.2))
    for name, d in runs.items():
        s = d[d["stage"] == "shear"]
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
    f1 = os.path.join(dest, "shear.png")
    fig.savefig(f1, dpi=120)

    fig, ax = plt.subplots(figsize=(6, 4))
    for name, d in runs.items():
        ax.plot(d["step"], 100 * d["energy_error"], label=name)
    ax.set_xlabel("step")
    ax.set_ylabel("energy balance error [% of boundary work]")
    ax.legend(fontsize=7)
    fig.tight_layout()
    f2 = os.path.join(dest, "energy.png")
    fig.savefig(f2, dpi=120)
    print(f"plots written: {f1}, {f2}")


if __name__ == "__main__":
    main()
