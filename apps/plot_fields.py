#!/usr/bin/python3
"""Slices of coarse-grained fields, and the shear band found in them (docs/fields.md).

    /usr/bin/python3 apps/plot_fields.py FIELDS.h5 [--case CASE] [--step STEP] [-o DIR]

FIELDS.h5: a file of `fabrica fields` or a run.h5 with field instants. The instant: --step, or
the case's last one with a strain increment (else its last). Draws DIR/fields_<case>_<step>.png
(DIR: beside FIELDS.h5 by default): six maps on the plane through the middle of axis 2 (axis 1
upwards, axis 3 across): the solid fraction, the local shear strain increment gamma (as
apps/localisation.py defines it), the deviatoric stress q = sqrt(3/2 s':s') of the `stress`
field, the spin magnitude, and the fabric anisotropy a of the strong and the weak network; with a
band found (apps/localisation.py), its centre plane's trace drawn on every map and the band's
angle, thickness and localisation index in the title. A field the file does not hold is left
blank with its name. A sheared cell's grid is cut in fractional coordinates s = H^-1 x: its maps
are drawn on the plane s2 = 1/2 against s3 and s1 (each from 0 to 1, labelled as fractional), the
band's trace the planes (h, k, l).s = c.
"""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import fabrica_h5  # noqa: E402
import localisation as lo  # noqa: E402


def deviatoric_q(s):
    s = 0.5 * (s + np.swapaxes(s, -1, -2))
    dev = s - np.trace(s, axis1=-2, axis2=-1)[..., None, None] / 3 * np.eye(3)
    return np.sqrt(1.5 * np.einsum("...ij,...ij->...", dev, dev))


def anisotropy_field(phi):
    a = 7.5 * (phi - np.trace(phi, axis1=-2, axis2=-1)[..., None, None] / 3 * np.eye(3))
    return np.sqrt(1.5 * np.einsum("...ij,...ij->...", a, a))


def maps(fields):
    """name -> (title, 3-D scalar array or None)."""
    f = fields
    out = {"solid_fraction": ("solid fraction", f.get("solid_fraction"))}
    out["gamma"] = ("shear strain increment gamma",
                    lo.shear_intensity(f["strain_increment"]) if "strain_increment" in f else None)
    out["q"] = ("q of the stress field [kPa]", deviatoric_q(f["stress"]) / 1e3 if "stress" in f else None)
    out["spin"] = ("|spin| [rad/s]", np.linalg.norm(f["spin"], axis=-1) if "spin" in f else None)
    out["a_s"] = ("fabric anisotropy, strong network", anisotropy_field(f["fabric_s"]) if "fabric_s" in f else None)
    out["a_ns"] = ("fabric anisotropy, weak network", anisotropy_field(f["fabric_ns"]) if "fabric_ns" in f else None)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("file")
    ap.add_argument("--case")
    ap.add_argument("--step", type=int)
    ap.add_argument("-o", "--outdir")
    a = ap.parse_args()
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    try:
        run = fabrica_h5.RunFile(a.file)
        instants = run.field_instants(a.case)
    except fabrica_h5.FabricaFileError as e:
        sys.exit(f"plot_fields.py: {e}")
    if not instants:
        sys.exit(f"plot_fields.py: {a.file}: no field instants")
    case = a.case or instants[-1].case
    mine = [i for i in instants if i.case == case]
    if a.step is not None:
        mine = [i for i in mine if i.step == a.step]
        if not mine:
            sys.exit(f"plot_fields.py: {a.file}: no fields of case '{case}' at step {a.step}")
        info = mine[0]
    else:
        with_strain = [i for i in mine if "strain_increment" in i.names]
        info = (with_strain or mine)[-1]
    fields = run.fields(case, info.step)
    band = None
    title = f"{case}, step {info.step}"
    if "strain_increment" in fields:
        row, _, band = lo.analyse(fields, info)
        title += f": localisation index {row['index']:.3f}"
        if row["band"]:
            title += (f", band at {row['angle_deg']:.1f} deg to the plane normal to axis 1, "
                      f"{row['thickness_m'] * 1e3:.1f} mm thick")
        else:
            band = None
            title += ", no band"
    sheared = getattr(info, "sheared", False)
    L = np.ones(3) if sheared else info.cell_lengths  # sheared: the fractional coordinates
    j = info.cells[1] // 2
    fig, axes = plt.subplots(2, 3, figsize=(13, 8.5), constrained_layout=True)
    for ax, (name, (label, v)) in zip(axes.ravel(), maps(fields).items()):
        ax.set_title(label, fontsize=10)
        ax.set_xlabel("s3 (fractional coordinate along edge 3)" if sheared else "x3 [m]")
        ax.set_ylabel("s1 (fractional coordinate along edge 1)" if sheared else "x1 [m] (loading axis)")
        if v is None:
            ax.text(0.5, 0.5, f"{name}: not in the file", ha="center", va="center", transform=ax.transAxes)
            continue
        im = ax.imshow(v[:, j, :], origin="lower", extent=[0, L[2], 0, L[0]], aspect="equal", cmap="viridis")
        fig.colorbar(im, ax=ax, shrink=0.8)
        if band is not None:
            # The band's centre planes h x1/L1 + k x2/L2 + l x3/L3 = c (mod 1) on the slice x2 = mid
            # (sheared: h s1 + k s2 + l s3 = c, L = 1).
            h, k, l = band["mode"]
            x2 = (j + 0.5) * L[1] / info.cells[1]
            prof = band["profile"]
            c = (np.nanargmax(prof) + 0.5) / lo.SLABS
            x3 = np.linspace(0, L[2], 200)
            if h != 0:
                for m in range(-3, 4):
                    x1 = (c + m - k * x2 / L[1] - l * x3 / L[2]) * L[0] / h
                    keep = (x1 >= 0) & (x1 <= L[0])
                    ax.plot(x3[keep], x1[keep], "w--", lw=1)
    if sheared:
        title += "\nsheared cell: maps on the plane s2 = 1/2 in fractional coordinates s = H^-1 x"
    fig.suptitle(title, fontsize=11)
    outdir = a.outdir or os.path.dirname(os.path.abspath(a.file))
    os.makedirs(outdir, exist_ok=True)
    path = os.path.join(outdir, f"fields_{case}_{info.step}.png")
    fig.savefig(path, dpi=90)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
