#!/usr/bin/python3
"""check_consolidations.py OUT N: OUT/consolidations.csv of an ensemble with consolidation
frictions (docs/triaxial.md "Realisations") has N rows, one per consolidation, each the last row
of its run's consolidation.csv (p, void ratio, Z at the end of the consolidation, to the digit),
and in every realisation the void ratio grows with the consolidation friction (a rougher
consolidation packs looser: the study's figure 2(b))."""
import csv
import os
import sys

out, n = sys.argv[1], int(sys.argv[2])
with open(os.path.join(out, "consolidations.csv")) as f:
    rows = list(csv.DictReader(f))
if len(rows) != n:
    sys.exit(f"consolidations.csv has {len(rows)} rows, expected {n}")
bad = 0
for r in rows:
    seed, mu = r["seed"], float(r["consolidation_friction"])
    name = f"seed_{seed}"
    dirs = [d for d in os.listdir(out) if d == name or d.startswith(name + "_consolidation_")]
    mine = [d for d in dirs if (d == name and mu == 1.0) or d.endswith(f"_consolidation_{r['consolidation_friction']}")]
    if len(mine) != 1:
        sys.exit(f"no single directory of seed {seed}, mu_s {mu}: {dirs}")
    with open(os.path.join(out, mine[0], "consolidation.csv")) as f:
        last = list(csv.DictReader(f))[-1]
    for k in ("step", "p", "void_ratio", "Z"):
        if last[k] != r[k]:
            print(f"seed {seed}, mu_s {mu}: {k} {r[k]} in consolidations.csv, {last[k]} in {mine[0]}")
            bad += 1
by_seed = {}
for r in rows:
    by_seed.setdefault(r["seed"], []).append((float(r["consolidation_friction"]), float(r["void_ratio"])))
for seed, v in by_seed.items():
    v.sort()
    print(f"seed {seed}: (mu_s, void ratio) {v}")
    if any(b[1] <= a[1] for a, b in zip(v, v[1:])):
        print(f"seed {seed}: the void ratio does not grow with the consolidation friction")
        bad += 1
sys.exit(1 if bad else 0)
