#!/usr/bin/python3
"""Figures of docs/accuracy.md from the CSV files of bench_accuracy.

    /usr/bin/python3 benchmarks/plot_accuracy.py SRC DST [TAG]
    e.g. benchmarks/accuracy docs/figures, or benchmarks/accuracy/short docs/figures _short

Writes accuracy_impact.png (if SRC has impact.csv), accuracy_pareto{TAG}.png,
accuracy_families{TAG}.png, accuracy_curves{TAG}.png and prints the Pareto front (settings not
beaten in both CPU time and error by another setting) and the noise floor (two runs that differ
only in rounding: skin 0.5 mm and 1 mm at fraction 0.25).
"""
import csv
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def num(r, k):
    return float(r[k])


def label(r):
    fam = r["family"]
    if fam.startswith("ref"):
        return fam
    if fam == "dt":
        return f"dt {num(r, 'fraction'):g}"
    if fam == "skin":
        return f"skin {1e3 * num(r, 'skin'):g} mm"
    if fam == "rate":
        return f"rate {num(r, 'rate'):g}/s"
    if fam == "combo":
        return f"dt {num(r, 'fraction'):g} + rate {num(r, 'rate'):g}/s + skin {1e3 * num(r, 'skin'):g} mm"
    return f"ds {num(r, 'density_scaling'):g}"


def noise_floor(cur, key):
    """RMS difference of two runs that differ only in rounding (skin 1 mm and 0.5 mm at fraction
    0.25: the skin changes when the particles are reordered, hence the order of the sums)."""
    a = [c for c in cur if c["family"] == "dt" and c["fraction"] == "0.25"]
    b = [c for c in cur if c["family"] == "skin" and c["skin"] == "0.0005"]
    n = min(len(a), len(b))
    if n == 0:
        return None
    return math.sqrt(sum((num(a[k], key) - num(b[k], key)) ** 2 for k in range(n)) / n)


def pareto(rows, cost, err):
    """Rows not dominated (another row with cost <= and err <=, one of them strictly)."""
    front = []
    for r in rows:
        dominated = any(
            (cost(o) <= cost(r) and err(o) <= err(r)) and (cost(o) < cost(r) or err(o) < err(r))
            for o in rows
        )
        if not dominated:
            front.append(r)
    return sorted(front, key=cost)


def main(src, dst, tag=""):
    import os
    imp = read(f"{src}/impact.csv") if os.path.exists(f"{src}/impact.csv") else None
    tri = read(f"{src}/triaxial.csv")
    cur = read(f"{src}/triaxial_curves.csv")
    colors = {"dt": "C0", "skin": "C1", "rate": "C2", "density": "C3", "combo": "C4", "ref_dt": "k",
              "ref_rate": "0.5"}

    if imp:
        plot_impact(imp, dst)
    plot_triaxial(tri, cur, dst, tag, colors)


def plot_impact(imp, dst):
    # Impact errors against the time-step fraction.
    fig, ax = plt.subplots(figsize=(6, 4.2))
    el = [r for r in imp if r["case"] == "elastic"]
    vi = [r for r in imp if r["case"] == "viscous"]
    fr = [num(r, "fraction") for r in el]
    ax.loglog(fr, [abs(num(r, "contact_time_error")) for r in el], "o-", label="elastic: contact time")
    ax.loglog(fr, [max(abs(num(r, "rebound_error")), 1e-9) for r in el], "s-", label="elastic: rebound speed")
    ax.loglog([num(r, "fraction") for r in vi], [abs(num(r, "rebound_error")) for r in vi], "^-",
              label="viscous beta 0.2: restitution")
    ref = [f * f / 12 for f in fr]  # (w dt)^2 / 24 with w dt = sqrt(2) f (two equal spheres)
    ax.loglog(fr, ref, "k--", lw=0.8, label="(w dt)^2 / 24 (Verlet period shift)")
    ax.set_xlabel("time step / critical estimate")
    ax.set_ylabel("relative error")
    ax.set_title("Two-sphere impact against the closed forms")
    ax.legend(fontsize=8)
    ax.grid(True, which="both", lw=0.3)
    fig.tight_layout()
    fig.savefig(f"{dst}/accuracy_impact.png", dpi=120)


def plot_triaxial(tri, cur, dst, tag, colors):

    # Pareto: error against CPU time, both curves.
    rows = [r for r in tri if not r["family"].startswith("ref")]
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    for ax, key, name in ((axes[0], "rms_qp", "RMS error of q/p"), (axes[1], "rms_epsv", "RMS error of eps_v")):
        for r in rows:
            c = num(r, "cpu_seconds")
            e = max(num(r, key), 1e-7)
            ax.loglog(c, e, "o", color=colors[r["family"]])
            ax.annotate(label(r), (c, e), fontsize=6, xytext=(3, 2), textcoords="offset points")
        # One front per reference (errors against different references are not comparable).
        for refname, style in (("ref_dt", "k-"), ("ref_rate", "k:")):
            sub = [r for r in rows if r["reference"] == refname]
            fr_ = pareto(sub, lambda r: num(r, "cpu_seconds"), lambda r: num(r, key))
            ax.loglog([num(r, "cpu_seconds") for r in fr_], [max(num(r, key), 1e-7) for r in fr_], style,
                      lw=0.8, label=f"Pareto front (against {refname})")
        for fam in ("dt", "skin", "rate", "density", "combo"):
            ax.plot([], [], "o", color=colors[fam], label=fam)
        floor = noise_floor(cur, "q_p" if key == "rms_qp" else "eps_v")
        if floor:
            ax.axhline(floor, color="0.6", lw=0.8, ls="--", label="noise floor (rounding only)")
        ax.set_xlabel("CPU seconds of the shear stage")
        ax.set_ylabel(name)
        ax.grid(True, which="both", lw=0.3)
        ax.legend(fontsize=7)
    fig.suptitle("Small triaxial test: error against run time")
    fig.tight_layout()
    fig.savefig(f"{dst}/accuracy_pareto{tag}.png", dpi=120)

    # Each family against its parameter, with the CPU time.
    fig, axes = plt.subplots(1, 4, figsize=(15, 3.8))
    spec = (("dt", "fraction", "time step / critical estimate"), ("skin", "skin", "skin [m]"),
            ("rate", "inertial_number", "inertial number (rate family)"),
            ("density", "density_scaling", "density scaling factor"))
    for ax, (fam, key, xl) in zip(axes, spec):
        sub = sorted([r for r in tri if r["family"] == fam], key=lambda r: num(r, key))
        x = [num(r, key) for r in sub]
        ax.loglog(x, [max(num(r, "rms_qp"), 1e-7) for r in sub], "o-", label="RMS q/p")
        ax.loglog(x, [max(num(r, "rms_epsv"), 1e-7) for r in sub], "s-", label="RMS eps_v")
        ax2 = ax.twinx()
        ax2.semilogx(x, [num(r, "cpu_seconds") for r in sub], "k^--", lw=0.8, label="CPU s")
        ax2.set_ylabel("CPU seconds")
        ax.set_xlabel(xl)
        ax.grid(True, which="both", lw=0.3)
        ax.legend(fontsize=7, loc="upper left")
        ax2.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    fig.savefig(f"{dst}/accuracy_families{tag}.png", dpi=120)

    # Curves.
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    def pick(c):
        fam = c["family"]
        if fam in ("ref_dt", "ref_rate"):
            return True
        if fam == "dt" and c["fraction"] == "1":
            return True
        if fam == "rate" and c["rate"] in ("0.5", "5"):
            return True
        if fam == "density" and c["density_scaling"] == "100":
            return True
        return False
    groups = {}
    for c in cur:
        if pick(c):
            groups.setdefault(label(c), []).append(c)
    for name, pts in groups.items():
        e = [num(p, "eps1") for p in pts]
        axes[0].plot(e, [num(p, "q_p") for p in pts], label=name)
        axes[1].plot(e, [num(p, "eps_v") for p in pts], label=name)
    axes[0].set_ylabel("q/p")
    axes[1].set_ylabel("eps_v (compression positive)")
    for ax in axes:
        ax.set_xlabel("eps_1")
        ax.grid(True, lw=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(f"{dst}/accuracy_curves{tag}.png", dpi=120)

    for key in ("rms_qp", "rms_epsv"):
        for refname in ("ref_dt", "ref_rate"):
            sub = [r for r in rows if r["reference"] == refname]
            fr_ = pareto(sub, lambda r: num(r, "cpu_seconds"), lambda r: num(r, key))
            print(f"Pareto front, {key} against {refname}: " +
                  ", ".join(f"{label(r)} ({num(r, 'cpu_seconds'):.2f} s, {num(r, key):.2e})" for r in fr_))
    # Noise floor: runs that differ only in rounding (the skin changes the order of the sums).
    def curve(fam, key, val):
        return [c for c in cur if c["family"] == fam and c[key] == val]
    a, b = curve("dt", "fraction", "0.25"), curve("skin", "skin", "0.0005")
    if a and b:
        n = min(len(a), len(b))
        for key in ("q_p", "eps_v"):
            d = [num(a[k], key) - num(b[k], key) for k in range(n)]
            print(f"noise floor ({key}, skin 1 mm vs 0.5 mm at fraction 0.25): RMS "
                  f"{math.sqrt(sum(x * x for x in d) / n):.2e}, max {max(abs(x) for x in d):.2e}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "benchmarks/accuracy",
         sys.argv[2] if len(sys.argv) > 2 else "docs/figures",
         sys.argv[3] if len(sys.argv) > 3 else "")
