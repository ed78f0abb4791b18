#!/usr/bin/python3
"""`fabrica fabric` (offline, from the snapshots of run.h5) against the analysis the run made
itself (docs/fabric.md): at every step where both exist (the end of every stage, and snapshots
that fall on an output row), the rows of fabric.csv, sff.csv and rose.csv must be identical
text after the stage column (the same contacts, the same exact sums, the same formatting).

    check_fabric_offline.py RUN_DIR OFFLINE_DIR
"""
import csv
import os
import sys


def rows(path):
    by_step = {}
    with open(path) as f:
        r = csv.reader(f)
        next(r)
        for row in r:
            by_step.setdefault(int(row[1]), []).append(row[1:])
    return by_step


def main():
    run, off = sys.argv[1], sys.argv[2]
    cases = sorted(d for d in os.listdir(off) if os.path.isdir(os.path.join(off, d)))
    if not cases:
        sys.exit(f"no case directories under {off}")
    compared = 0
    for case in cases:
        for name in ("fabric.csv", "sff.csv", "rose.csv"):
            online = (os.path.join(run, "consolidation_" + name) if case == "consolidation"
                      else os.path.join(run, case, name))
            a, b = rows(online), rows(os.path.join(off, case, name))
            common = sorted(set(a) & set(b))
            if not common:
                sys.exit(f"{case}/{name}: no step in common between the run and the offline analysis")
            for s in common:
                if a[s] != b[s]:
                    for x, y in zip(a[s], b[s]):
                        if x != y:
                            print("run:    ", ",".join(x), "\noffline:", ",".join(y))
                            break
                    sys.exit(f"{case}/{name}: step {s} differs")
            compared += len(common)
            print(f"{case}/{name}: identical at steps {common}")
    print(f"{compared} instants compared, all identical")


if __name__ == "__main__":
    main()
