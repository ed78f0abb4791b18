#!/usr/bin/python3
"""Tile the shared dense-13584 packing into a larger periodic specimen.

    /usr/bin/python3 benchmarks/make_tiled.py N OUT.data [SOURCE.data]

writes N x N x N copies of SOURCE (default ../shared/bench/dense-13584/dense.data) into a
box N times as long on every axis, as a LAMMPS/LIGGGHTS data file (atom_style sphere:
id type diameter density x y z). The spheres are listed tile by tile (all of tile 0, then
tile 1, ...), with ids 1 .. N^3 n, as a user's file assembled from copies would be. The
packing is periodic, so the tiles join without overlaps beyond the source's own.
Standard library only.
"""
import sys
from pathlib import Path


def main():
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    n = int(sys.argv[1])
    if n < 1:
        sys.exit(f"make_tiled.py: N = {n} must be at least 1")
    out = Path(sys.argv[2])
    src = Path(sys.argv[3]) if len(sys.argv) == 4 else \
        Path(__file__).resolve().parent.parent.parent / "shared/bench/dense-13584/dense.data"
    lines = src.read_text().splitlines()
    lo, hi, atoms, ntypes = [0.0] * 3, [0.0] * 3, [], 1
    k = 0
    while k < len(lines):
        t = lines[k].split()
        if len(t) >= 4 and t[2].endswith("lo") and t[3].endswith("hi"):
            ax = "xyz".index(t[2][0])
            lo[ax], hi[ax] = float(t[0]), float(t[1])
        elif len(t) >= 3 and t[1] == "atom" and t[2] == "types":
            ntypes = int(t[0])
        elif t and t[0] == "Atoms":
            k += 1
            while k < len(lines) and not lines[k].split():
                k += 1
            while k < len(lines) and lines[k].split():
                atoms.append(lines[k].split())
                k += 1
            break
        k += 1
    if not atoms:
        sys.exit(f"make_tiled.py: {src}: no Atoms section")
    L = [hi[a] - lo[a] for a in range(3)]
    count = n ** 3 * len(atoms)
    with out.open("w") as f:
        f.write(f"{src.name} tiled {n}x{n}x{n} by benchmarks/make_tiled.py\n\n")
        f.write(f"{count} atoms\n{ntypes} atom types\n\n")
        for a, name in enumerate("xyz"):
            f.write(f"{lo[a]!r} {lo[a] + n * L[a]!r} {name}lo {name}hi\n")
        f.write("\nAtoms\n\n")
        gid = 0
        for tz in range(n):
            for ty in range(n):
                for tx in range(n):
                    off = (tx * L[0], ty * L[1], tz * L[2])
                    for t in atoms:
                        gid += 1
                        x = [float(t[4 + a]) + off[a] for a in range(3)]
                        f.write(f"{gid} {t[1]} {t[2]} {t[3]} {x[0]!r} {x[1]!r} {x[2]!r}\n")
    print(f"{out}: {count} spheres, box {n * L[0]:.6g} x {n * L[1]:.6g} x {n * L[2]:.6g} m")


if __name__ == "__main__":
    main()
