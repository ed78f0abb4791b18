#!/usr/bin/python3
"""apps/localisation.py against fields whose band is known (docs/fields.md "Shear bands").

    check_localisation.py synthetic
    check_localisation.py file FIELDS.h5 OUTDIR   (the command on a real file: rows and columns)

synthetic: a strain increment of pure shear, gamma = 1 + 9 exp(-d^2 / (2 sigma^2)) with d the
distance to the planes of a periodic band of normal (1/L1, 0, 1/L3) (the mode (1, 0, 1)) in a
cell of 0.3 x 0.2 x 0.25 m on a 60 x 40 x 50 grid, sigma = 20 mm:
- the mode (1, 0, 1) found, the normal and the angle acos(n1) = 50.19 deg to 1e-12;
- the thickness within two slabs (2/64 of the band spacing, 6 mm) of the Gaussian's full width at
  half maximum 2 sqrt(2 ln 2) sigma = 47.1 mm;
- gamma inside above gamma outside, the band found at the contrast 2;
- a homogeneous increment: index 0.1 (60 x 40 x 50 is a multiple of 10) to 1e-12 and no band; a
  field of 10 on one tenth of the nodes and 1 elsewhere: index 10/19 to 1e-12;
- the theory angles of a mean stress diag(300, 200, 100) kPa (sin phi = 1/2: phi = 30 deg) and a
  mean strain increment diag(-0.002, 0.0005, 0.0025) (sin psi = -(d1 + d3)/(d1 - d3) = 1/9) to
  1e-9 degrees, and theta_mc = 45 + phi/2;
- a sheared cell (H with a tilt of 0.12 m of edge 3 along x, the grid in fractional
  coordinates): a band of the mode (1, 0, 1) planted at the real-space distance d to the planes
  of normal H^-T (1, 0, 1): the mode, the normal and the angle to 1e-12, the thickness within two
  slabs of the FWHM, found inside above outside.
"""
import csv
import math
import os
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
APPS = os.path.join(HERE, "..", "..", "apps")
sys.path.insert(0, APPS)
import localisation as lo  # noqa: E402

failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


class Info:
    def __init__(self, L, H=None):
        self.case, self.step, self.time, self.cell_lengths = "synthetic", 0, 0.0, np.asarray(L)
        self.cell_matrix = np.diag(L) if H is None else np.asarray(H)


def shear_field(gamma, n):
    """Pure shear e = gamma/2 (t n + n t), t a unit vector normal to n: sqrt(2 e':e') = gamma."""
    t = np.cross(n, [0.0, 1.0, 0.0])
    t /= np.linalg.norm(t)
    base = 0.5 * (np.outer(t, n) + np.outer(n, t))
    return gamma[..., None, None] * base


def synthetic():
    L = np.array([0.3, 0.2, 0.25])
    cells = (60, 40, 50)
    X, Y, Z = lo.node_positions(cells, L)
    q = np.array([1 / L[0], 0.0, 1 / L[2]])
    spacing = 1 / np.linalg.norm(q)
    n = q * spacing
    s = np.mod(X / L[0] + Z / L[2], 1.0)
    d = np.abs(((s - 0.37 + 0.5) % 1.0) - 0.5) * spacing
    sigma = 0.02
    gamma = 1 + 9 * np.exp(-d * d / (2 * sigma * sigma))
    fields = {"strain_increment": shear_field(gamma, n)}
    row, g, b = lo.analyse(fields, Info(L))
    check(np.max(np.abs(g - gamma)) < 1e-12, f"gamma = sqrt(2 e':e') of the planted field (max error {np.max(np.abs(g - gamma)):.1e})")
    check((row["h"], row["k"], row["l"]) == (1, 0, 1), f"mode (1, 0, 1) found: ({row['h']}, {row['k']}, {row['l']})")
    angle = math.degrees(math.acos(n[0]))
    check(abs(row["angle_deg"] - angle) < 1e-12, f"angle {row['angle_deg']:.6f} deg, planted {angle:.6f}")
    check(np.max(np.abs(np.array([row["n1"], row["n2"], row["n3"]]) - n)) < 1e-12, "normal as planted")
    fwhm = 2 * math.sqrt(2 * math.log(2)) * sigma
    check(abs(row["thickness_m"] - fwhm) <= 2 * spacing / lo.SLABS,
          f"thickness {row['thickness_m'] * 1e3:.2f} mm, FWHM {fwhm * 1e3:.2f} mm (within {2 * spacing / lo.SLABS * 1e3:.2f} mm)")
    check(row["band"] == 1 and row["gamma_in"] > row["gamma_out"],
          f"band found, gamma in {row['gamma_in']:.3f} > out {row['gamma_out']:.3f}")

    uniform = np.ones(cells)
    fields = {"strain_increment": shear_field(uniform, n)}
    row, _, _ = lo.analyse(fields, Info(L))
    check(abs(row["index"] - 0.1) < 1e-12 and row["band"] == 0, f"homogeneous: index {row['index']:.15f}, band {row['band']}")
    tenth = np.ones(cells)
    tenth[:6] = 10.0  # the first 6 of 60 layers: one tenth of the nodes
    check(abs(lo.localisation_index(tenth) - 10 / 19) < 1e-12, f"one tenth at 10: index {lo.localisation_index(tenth):.15f}, 10/19")

    stress = np.broadcast_to(np.diag([300e3, 200e3, 100e3]), cells + (3, 3))
    strain = np.broadcast_to(np.diag([-0.002, 0.0005, 0.0025]), cells + (3, 3))
    t = lo.theory_angles({"stress": stress, "strain_increment": strain}, np.ones(cells, bool))
    psi = math.degrees(math.asin(-(-0.002 + 0.0025) / (-0.002 - 0.0025)))
    check(abs(t["phi"] - 30) < 1e-9 and abs(t["psi"] - psi) < 1e-9 and abs(t["theta_mc"] - 60) < 1e-9,
          f"phi {t['phi']:.9f} (30), psi {t['psi']:.9f} ({psi:.9f}), theta_mc {t['theta_mc']:.9f} (60)")


def synthetic_sheared():
    H = np.array([[0.3, 0.0, 0.12], [0.0, 0.2, 0.0], [0.0, 0.0, 0.25]])
    cells = (60, 40, 50)
    S = np.meshgrid(*[(np.arange(n) + 0.5) / n for n in cells], indexing="ij")  # fractional coordinates
    q = np.linalg.solve(H.T, np.array([1.0, 0.0, 1.0]))  # the reciprocal-lattice vector of (1, 0, 1)
    spacing = 1 / np.linalg.norm(q)
    n = q * spacing
    s = np.mod(S[0] + S[2], 1.0)  # q.x = (1, 0, 1).s
    d = np.abs(((s - 0.37 + 0.5) % 1.0) - 0.5) * spacing  # real-space distance to the band's planes
    sigma = 0.02
    gamma = 1 + 9 * np.exp(-d * d / (2 * sigma * sigma))
    row, g, b = lo.analyse({"strain_increment": shear_field(gamma, n)}, Info(np.diag(H), H))
    check((row["h"], row["k"], row["l"]) == (1, 0, 1), f"sheared: mode (1, 0, 1) found: ({row['h']}, {row['k']}, {row['l']})")
    angle = math.degrees(math.acos(abs(n[0])))
    check(abs(row["angle_deg"] - angle) < 1e-12, f"sheared: angle {row['angle_deg']:.6f} deg, planted {angle:.6f} "
          f"(orthorhombic cell of the same lengths: {math.degrees(math.acos(0.25 / math.hypot(0.3, 0.25))):.6f})")
    check(np.max(np.abs(np.array([row["n1"], row["n2"], row["n3"]]) - n)) < 1e-12, "sheared: normal H^-T m as planted")
    check(abs(row["spacing_m"] - spacing) < 1e-12, f"sheared: band spacing {row['spacing_m']:.6f} m, 1/|H^-T m|")
    fwhm = 2 * math.sqrt(2 * math.log(2)) * sigma
    check(abs(row["thickness_m"] - fwhm) <= 2 * spacing / lo.SLABS,
          f"sheared: thickness {row['thickness_m'] * 1e3:.2f} mm, FWHM {fwhm * 1e3:.2f} mm")
    check(row["band"] == 1 and row["gamma_in"] > row["gamma_out"],
          f"sheared: band found, gamma in {row['gamma_in']:.3f} > out {row['gamma_out']:.3f}")


def on_file(path, outdir):
    os.makedirs(outdir, exist_ok=True)
    out = os.path.join(outdir, "loc.csv")
    r = subprocess.run([sys.executable, os.path.join(APPS, "localisation.py"), path, "-o", out],
                       capture_output=True, text=True)
    print(r.stdout + r.stderr)
    check(r.returncode == 0, "localisation.py exits 0")
    with open(out, newline="") as f:
        rows = list(csv.DictReader(f))
    check(len(rows) >= 1 and list(rows[0].keys()) == lo.COLUMNS, f"{len(rows)} row(s) with the documented columns")
    for row in rows:
        idx = float(row["index"])
        check(0.1 - 1e-12 <= idx <= 1, f"step {row['step']}: index {idx:.4f} in [0.1, 1]")


if __name__ == "__main__":
    if len(sys.argv) >= 2 and sys.argv[1] == "synthetic":
        synthetic()
        synthetic_sheared()
    elif len(sys.argv) == 4 and sys.argv[1] == "file":
        on_file(sys.argv[2], sys.argv[3])
    else:
        sys.exit(__doc__)
    sys.exit(1 if failures else 0)
