#!/usr/bin/python3
"""Shear bands found and measured in coarse-grained fields (docs/fields.md "Shear bands").

    /usr/bin/python3 apps/localisation.py FIELDS.h5 [--case CASE] [-o OUT.csv] [--contrast C]

FIELDS.h5 is a file of `fabrica fields ... --all` (it holds `strain_increment`, the strain between
each instant and the case's previous one) or a run.h5 whose field instants hold it. For every
instant with a strain increment, one row (printed, and written to OUT.csv, by default
localisation_<case>.csv beside FIELDS.h5):

- gamma(X) = sqrt(2 e':e'), e' the deviator of the strain increment at node X: the local
  equivalent shear strain of the increment (NaN nodes, out of every particle's reach, left out);
- the localisation index: the share of sum_X gamma carried by the tenth of the nodes where gamma
  is largest (the ceil(n / 10) largest of the n finite values; 0.1 for a homogeneous increment,
  towards 1 as the shear gathers in a band; the run's series column `localisation` is the same);
- the band: a band in a periodic cell repeats with the cell, so its normal is the direction of a
  reciprocal-lattice vector q = (h/L1, k/L2, l/L3) with integers h, k, l (a sheared cell of
  matrix H, its grid in fractional coordinates s: q = H^-T (h, k, l), the phase q.x = (h, k, l).s
  at node s = ((i, j, k) + 1/2) / cells). The mode of the
  discrete Fourier transform of gamma with the largest amplitude among |h|, |k|, |l| <= 2 (the
  primitive ones, gcd 1) gives the normal n = q/|q| and the spacing 1/|q| of the band's
  repetitions. gamma averaged over the nodes in 64 slabs along n over one spacing is the profile;
  a band is found when its peak is at least C (--contrast, default 2) times its median. Then:
  its angle theta = angle between n and axis 1 (the loading axis: the band plane's inclination to
  the plane normal to axis 1, as the Mohr-Coulomb 45 + phi/2 counts it), its thickness = the
  width of the profile's run above half of (peak + minimum) around the peak (the full width at
  half maximum), and the mean gamma, solid fraction and each network's fabric anisotropy inside
  (nodes within half the thickness of the band's centre plane) and outside;
- the angles the theories give, from the instant's mean stress and strain increment: phi the
  mobilised friction angle, sin phi = (s1 - s3) / (s1 + s3) of the principal values of the mean
  `stress` field (compression positive), psi the dilatancy angle, sin psi = -(d1 + d3) / (d1 - d3)
  of the principal strain increments (extension positive, d1 the most compressive);
  theta_mc = 45 + phi/2 (Mohr-Coulomb), theta_roscoe = 45 + psi/2, theta_arthur = 45 + (phi + psi)/4.

The fabric anisotropy of a network k is a = sqrt(3/2 a_ij a_ij), a_ij = 15/2 (phi_ij - delta_ij/3),
of the mean of its fabric field over the nodes inside (or outside) where it is defined.
"""
import argparse
import csv
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import fabrica_h5  # noqa: E402

MAX_INDEX = 2
SLABS = 64
NETWORKS = ("all", "s", "ns", "sf", "wf")


def shear_intensity(e):
    """gamma = sqrt(2 e':e') at every node of a strain-increment field (nx, ny, nz, 3, 3)."""
    e = 0.5 * (e + np.swapaxes(e, -1, -2))
    tr = np.trace(e, axis1=-2, axis2=-1)
    dev = e - tr[..., None, None] / 3.0 * np.eye(3)
    return np.sqrt(2.0 * np.einsum("...ij,...ij->...", dev, dev))


def localisation_index(gamma):
    """The share of sum(gamma) in the tenth of the (defined) nodes where gamma is largest: the
    ceil(n / 10) largest of the n finite values, counted in integers as (n + 9) // 10 (as the run's
    series column, core/localisation.cpp)."""
    g = np.sort(gamma[np.isfinite(gamma)].ravel())[::-1]
    if g.size == 0 or g.sum() <= 0:
        return float("nan")
    top = (g.size + 9) // 10
    return float(g[:top].sum() / g.sum())


def node_positions(cells, lengths):
    """The node centres (i + 1/2) L / n along each axis, as three (nx, ny, nz) arrays."""
    axes = [(np.arange(n) + 0.5) * L / n for n, L in zip(cells, lengths)]
    return np.meshgrid(*axes, indexing="ij")


def primitive_modes(limit=MAX_INDEX):
    """The integer triples (h, k, l), |each| <= limit, gcd 1, one of each +- pair."""
    out = []
    for h in range(-limit, limit + 1):
        for k in range(-limit, limit + 1):
            for l in range(-limit, limit + 1):
                if (h, k, l) == (0, 0, 0) or math.gcd(math.gcd(abs(h), abs(k)), abs(l)) != 1:
                    continue
                if (h, k, l) > (0, 0, 0):  # lexicographic: one of (m, -m)
                    out.append((h, k, l))
    return out


def band_of(gamma, lengths, contrast=2.0, matrix=None):
    """The band (dict) of a gamma field on the grid of a cell of the given lengths (or, sheared,
    of the cell matrix 'matrix': its grid in fractional coordinates), or None."""
    cells = gamma.shape
    sheared = matrix is not None and bool((np.asarray(matrix)[~np.eye(3, dtype=bool)] != 0).any())
    if sheared:  # each mode's phase (h, k, l).s over the fractional coordinates of the nodes
        S = np.meshgrid(*[(np.arange(n) + 0.5) / n for n in cells], indexing="ij")
        frac = lambda m: m[0] * S[0] + m[1] * S[1] + m[2] * S[2]  # noqa: E731
    else:
        X, Y, Z = node_positions(cells, lengths)
        frac = lambda m: m[0] * X / lengths[0] + m[1] * Y / lengths[1] + m[2] * Z / lengths[2]  # noqa: E731
    ok = np.isfinite(gamma)
    g = np.where(ok, gamma, 0.0)
    mean = g[ok].mean()
    best, best_amp = None, -1.0
    for m in primitive_modes():
        phase = 2 * np.pi * frac(m)
        amp = abs(np.sum(np.where(ok, (g - mean) * np.exp(-1j * phase), 0.0)))
        if amp > best_amp + 1e-12 * max(1.0, best_amp):
            best, best_amp = m, amp
    if sheared:  # the reciprocal lattice: q = H^-T m
        q = np.linalg.solve(np.asarray(matrix, dtype=np.float64).T, np.asarray(best, dtype=np.float64))
    else:
        q = np.array([best[0] / lengths[0], best[1] / lengths[1], best[2] / lengths[2]])
    spacing = 1.0 / np.linalg.norm(q)
    n = q * spacing
    s = np.mod(frac(best), 1.0)
    slab = np.minimum((s * SLABS).astype(int), SLABS - 1)
    sums = np.bincount(slab[ok], weights=g[ok], minlength=SLABS)
    counts = np.bincount(slab[ok], minlength=SLABS)
    profile = np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)
    filled = profile[np.isfinite(profile)]
    peak_slab = int(np.nanargmax(profile))
    peak, low, median = float(np.nanmax(profile)), float(np.nanmin(profile)), float(np.median(filled))
    result = {"mode": best, "normal": n, "spacing": spacing, "profile": profile, "peak": peak,
              "median": median, "found": bool(median > 0 and peak >= contrast * median)}
    # The run above half of (peak + minimum) around the peak, slabs taken cyclically.
    half = 0.5 * (peak + low)
    width = 1
    for step in (1, -1):
        j = peak_slab + step
        while width < SLABS and np.isfinite(profile[j % SLABS]) and profile[j % SLABS] >= half:
            width += 1
            j += step
    result["thickness"] = width / SLABS * spacing
    # The centre: the circular mean of the slabs of the run, weighted by gamma above half.
    centre = (peak_slab + 0.5) / SLABS
    d = np.abs(((s - centre + 0.5) % 1.0) - 0.5) * spacing  # distance to the centre plane
    result["inside"] = ok & (d <= 0.5 * result["thickness"])
    result["outside"] = ok & ~result["inside"]
    result["angle"] = math.degrees(math.acos(min(1.0, abs(n[0]))))
    return result


def anisotropy(phi):
    """a = sqrt(3/2 a_ij a_ij), a_ij = 15/2 (phi_ij - delta_ij / 3), of a fabric tensor."""
    a = 7.5 * (phi - np.trace(phi) / 3.0 * np.eye(3))
    return float(math.sqrt(1.5 * np.sum(a * a)))


def mean_tensor(field, where):
    v = field[where]
    v = v[np.all(np.isfinite(v.reshape(len(v), -1)), axis=1)]
    return v.mean(axis=0) if len(v) else np.full((3, 3), np.nan)


def theory_angles(fields, ok):
    """phi, psi and the Mohr-Coulomb, Roscoe and Arthur angles (degrees) of an instant."""
    out = {}
    if "stress" in fields:
        s = np.linalg.eigvalsh(0.5 * (mean_tensor(fields["stress"], ok) + mean_tensor(fields["stress"], ok).T))
        s1, s3 = s[-1], s[0]  # compression positive: s1 the largest
        out["phi"] = math.degrees(math.asin(max(-1.0, min(1.0, (s1 - s3) / (s1 + s3))))) if s1 + s3 > 0 else float("nan")
    e = mean_tensor(fields["strain_increment"], ok)
    d = np.linalg.eigvalsh(0.5 * (e + e.T))
    d1, d3 = d[0], d[-1]  # extension positive: d1 the most compressive
    out["psi"] = math.degrees(math.asin(max(-1.0, min(1.0, -(d1 + d3) / (d1 - d3))))) if d1 != d3 else float("nan")
    phi, psi = out.get("phi", float("nan")), out["psi"]
    out["theta_mc"], out["theta_roscoe"], out["theta_arthur"] = 45 + phi / 2, 45 + psi / 2, 45 + (phi + psi) / 4
    return out


COLUMNS = ["case", "step", "time", "index", "band", "h", "k", "l", "n1", "n2", "n3", "angle_deg", "thickness_m",
           "spacing_m", "gamma_in", "gamma_out", "solid_fraction_in", "solid_fraction_out", "phi_deg", "psi_deg",
           "theta_mc_deg", "theta_roscoe_deg", "theta_arthur_deg"] + \
          [f"a_{k}_{w}" for k in NETWORKS for w in ("in", "out")]


def analyse(fields, info, contrast=2.0):
    """One instant's row (dict of COLUMNS) from its fields (fabrica_h5.RunFile.fields)."""
    gamma = shear_intensity(fields["strain_increment"])
    ok = np.isfinite(gamma)
    row = {"case": info.case, "step": info.step, "time": info.time, "index": localisation_index(gamma)}
    b = band_of(gamma, info.cell_lengths, contrast, getattr(info, "cell_matrix", None))
    row.update(band=int(b["found"]), h=b["mode"][0], k=b["mode"][1], l=b["mode"][2], n1=b["normal"][0],
               n2=b["normal"][1], n3=b["normal"][2], angle_deg=b["angle"], thickness_m=b["thickness"],
               spacing_m=b["spacing"], gamma_in=float(np.mean(gamma[b["inside"]])) if b["inside"].any() else np.nan,
               gamma_out=float(np.mean(gamma[b["outside"]])) if b["outside"].any() else np.nan)
    phi = fields.get("solid_fraction")
    for w in ("in", "out"):
        where = b["inside" if w == "in" else "outside"]
        row[f"solid_fraction_{w}"] = float(np.mean(phi[where])) if phi is not None and where.any() else np.nan
        for k in NETWORKS:
            f = fields.get(f"fabric_{k}")
            row[f"a_{k}_{w}"] = anisotropy(mean_tensor(f, where)) if f is not None and where.any() else np.nan
    t = theory_angles(fields, ok)
    row.update(phi_deg=t.get("phi", np.nan), psi_deg=t["psi"], theta_mc_deg=t["theta_mc"],
               theta_roscoe_deg=t["theta_roscoe"], theta_arthur_deg=t["theta_arthur"])
    return row, gamma, b


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("file")
    ap.add_argument("--case")
    ap.add_argument("-o", "--output")
    ap.add_argument("--contrast", type=float, default=2.0)
    a = ap.parse_args()
    if not (a.contrast > 1):
        sys.exit(f"localisation.py: --contrast = {a.contrast}: must be above 1")
    try:
        f = fabrica_h5.RunFile(a.file)
        instants = [i for i in f.field_instants(a.case) if "strain_increment" in i.names]
    except fabrica_h5.FabricaFileError as e:
        sys.exit(f"localisation.py: {e}")
    if not instants:
        sys.exit(f"localisation.py: {a.file}: no field instant with a strain_increment "
                 "(make them with `fabrica fields RUN.h5 --all`, docs/fields.md)")
    rows = []
    for info in instants:
        row, _, _ = analyse(f.fields(info.case, info.step), info, a.contrast)
        rows.append(row)
        print(f"{info.case} step {info.step}: index {row['index']:.3f}, "
              + (f"band normal ({row['n1']:.3f}, {row['n2']:.3f}, {row['n3']:.3f}) at {row['angle_deg']:.1f} deg, "
                 f"thickness {row['thickness_m']:.4g} m (Mohr-Coulomb {row['theta_mc_deg']:.1f}, Roscoe "
                 f"{row['theta_roscoe_deg']:.1f}, Arthur {row['theta_arthur_deg']:.1f} deg)" if row["band"] else "no band"))
    out = a.output or os.path.join(os.path.dirname(os.path.abspath(a.file)),
                                   f"localisation_{a.case}.csv" if a.case else "localisation.csv")
    tmp = out + ".tmp"
    with open(tmp, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=COLUMNS)
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.10g}" if isinstance(v, float) else v) for k, v in r.items()})
    os.replace(tmp, out)
    print(f"{len(rows)} instant(s) written to {out}")


if __name__ == "__main__":
    main()
