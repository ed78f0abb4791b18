#!/usr/bin/python3
"""Plots the shear stages of a run (`fabrica run` with [[stage]]s that shear the cell; see
docs/shear.md) from OUT/series.csv and OUT/fabric.csv, as OUT/shear.png:

  tau against gamma      the shear stress tau = -s_ij (the compression-positive s_ij of a
                         positive shear is negative) against the engineering shear strain
                         gamma_ij of the component sheared most (ij printed on the axes);
  the stress path        tau and q against p;
  the major directions   the angle in the 1-2 plane of the stress's major principal direction
                         (series' theta_12) and of the fabric's (fabric.csv, network "all",
                         dir_1, dir_2), in degrees in (-90, 90], against gamma;
  non-coaxiality         the angle between the two (fabric.csv "noncoaxiality") and p / p0
                         against gamma.
Only the rows of the stages that shear are drawn (those whose shear strains move by 1 % of the
most any stage's do; the consolidation before them is left out).

    /usr/bin/python3 apps/plot_shear.py out/simple_shear [-o DIR]

Needs Debian's python3-numpy and python3-matplotlib (for /usr/bin/python3).
"""
import argparse
import csv
import math
import os
import sys

try:
    import numpy as np
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError as e:  # pragma: no cover
    sys.exit(f"plot_shear.py: {e}; install python3-numpy and python3-matplotlib "
             "and run with /usr/bin/python3")

COMPONENTS = ["12", "13", "23"]


def read_csv(path):
    """The rows of a CSV file as dicts of floats (the 'stage' and 'network' columns as text)."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    text = {"stage", "network"}
    return [{k: (v if k in text else float(v)) for k, v in r.items()} for r in rows]


def shear_stages(rows):
    """The stages (in order) whose shear strains moved, by at least 1 % of the most any did: those
    that sheared the cell (not a re-equilibration under shear-stress control)."""
    lo, hi = {}, {}
    for r in rows:
        for c in COMPONENTS:
            key = (r["stage"], c)
            lo[key] = min(lo.get(key, math.inf), r["gamma_" + c])
            hi[key] = max(hi.get(key, -math.inf), r["gamma_" + c])
    span = {}
    for (stage, c), v in hi.items():
        span[stage] = max(span.get(stage, 0.0), v - lo[(stage, c)])
    most = max(span.values(), default=0.0)
    return [s for s in span if most > 0 and span[s] >= 0.01 * most]


def load(outdir):
    series = os.path.join(outdir, "series.csv")
    try:
        rows = read_csv(series)
    except OSError as e:
        sys.exit(f"plot_shear.py: {e}")
    if not rows or "gamma_12" not in rows[0]:
        sys.exit(f"plot_shear.py: {series}: no shear columns (gamma_12 ...): no stage of this run shears "
                 "the cell (docs/shear.md)")
    stages = shear_stages(rows)
    if not stages:
        sys.exit(f"plot_shear.py: {series}: the shear strains never move: nothing to plot")
    rows = [r for r in rows if r["stage"] in stages]
    fabric = {}
    path = os.path.join(outdir, "fabric.csv")
    if os.path.exists(path):
        for r in read_csv(path):
            if r["network"] == "all" and r["stage"] in stages:
                fabric[int(r["step"])] = r
    return rows, fabric


def component(rows):
    """The shear component that moved most over the rows: '12', '13' or '23'."""
    def span(c):
        g = [r["gamma_" + c] for r in rows]
        return max(g) - min(g)
    return max(COMPONENTS, key=span)


def angle_12(n1, n2):
    """The angle of a direction's projection on the 1-2 plane from axis 1, in (-90, 90]."""
    if math.hypot(n1, n2) < 1e-12:
        return float("nan")
    a = math.degrees(math.atan2(n2, n1))
    if a <= -90:
        a += 180
    elif a > 90:
        a -= 180
    return a


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("outdir", help="output directory of fabrica run (series.csv, fabric.csv)")
    ap.add_argument("-o", "--output", help="directory for shear.png (default: OUTDIR)")
    a = ap.parse_args()
    rows, fabric = load(a.outdir)
    c = component(rows)
    gamma = np.array([r["gamma_" + c] for r in rows])
    sij = {"12": "s12", "13": "s13", "23": "s23"}[c]
    tau = np.array([-r[sij] for r in rows]) / 1e3
    p = np.array([r["p"] for r in rows]) / 1e3
    q = np.array([r["q"] for r in rows]) / 1e3
    theta = np.array([r["theta_12"] for r in rows])
    steps = [int(r["step"]) for r in rows]
    fab = [fabric.get(s) for s in steps]
    fab_theta = np.array([angle_12(f["dir_1"], f["dir_2"]) if f else np.nan for f in fab])
    noncoax = np.array([f["noncoaxiality"] if f and "noncoaxiality" in f else np.nan for f in fab])

    fig, ax = plt.subplots(2, 2, figsize=(11, 8))
    ax[0, 0].plot(gamma, tau, lw=1)
    ax[0, 0].set_xlabel(f"engineering shear strain gamma_{c}")
    ax[0, 0].set_ylabel(f"shear stress tau = -s{c} [kPa]")
    ax[0, 0].set_title("shear stress")
    ax[0, 1].plot(p, tau, lw=1, label=f"tau = -s{c}")
    ax[0, 1].plot(p, q, lw=1, ls="--", label="q")
    ax[0, 1].set_xlabel("p [kPa]")
    ax[0, 1].set_ylabel("[kPa]")
    ax[0, 1].set_title("stress path")
    ax[0, 1].legend(fontsize=8)
    ax[1, 0].plot(gamma, theta, ".", ms=3, label="stress (series theta_12)")
    if np.isfinite(fab_theta).any():
        ax[1, 0].plot(gamma, fab_theta, ".", ms=3, label="fabric phi, network all")
    ax[1, 0].set_xlabel(f"gamma_{c}")
    ax[1, 0].set_ylabel("major direction in the 1-2 plane [degrees from axis 1]")
    ax[1, 0].set_ylim(-90, 90)
    ax[1, 0].legend(fontsize=8)
    ax[1, 0].set_title("major principal directions")
    if np.isfinite(noncoax).any():
        ax[1, 1].plot(gamma, noncoax, ".", ms=3, label="non-coaxiality [degrees]")
    ax[1, 1].set_xlabel(f"gamma_{c}")
    ax[1, 1].set_ylabel("fabric / stress non-coaxiality [degrees]")
    ax[1, 1].set_ylim(0, 90)
    twin = ax[1, 1].twinx()
    twin.plot(gamma, p / p[0], color="gray", lw=1, label="p / p0")
    twin.set_ylabel("p / p0")
    ax[1, 1].set_title("non-coaxiality, and p")
    fig.suptitle(f"{os.path.abspath(a.outdir)}: stages {', '.join(dict.fromkeys(r['stage'] for r in rows))} "
                 f"(component {c})", fontsize=9)
    fig.tight_layout()
    out = a.output or a.outdir
    os.makedirs(out, exist_ok=True)
    path = os.path.join(out, "shear.png")
    fig.savefig(path, dpi=120)
    print(f"plot written: {path} (component {c}, {len(rows)} rows, gamma {gamma[0]:.4g} to {gamma[-1]:.4g}, "
          f"tau {tau.min():.4g} to {tau.max():.4g} kPa)")


if __name__ == "__main__":
    main()
