#!/usr/bin/python3
"""The floors of the tree (docs/design.md "The floors"): what each folder may include.

    /usr/bin/python3 tests/check_floors.py SOURCE_DIR

From the ground up: core/ (the physics, MPI-free) includes only core/; parallel/ (the ranks)
includes core/ and parallel/; io/serial/ (input and checked writes, MPI-free) includes core/
and io/serial/; io/mpi/ (run.h5, XDMF, checkpoints, the set-up over ranks) includes everything
below it; apps/ includes everything. core/ and io/serial/ name no MPI header. Every "..."
include of a .cpp or .hpp file of these folders is read; exit 1 naming each one that climbs.
"""
import os
import re
import sys

# folder -> the folders its files may include ("..." includes, by path from the root)
ALLOWED = {
    "core/": ("core/",),
    "parallel/": ("core/", "parallel/"),
    "io/serial/": ("core/", "io/serial/"),
    "io/mpi/": ("core/", "parallel/", "io/serial/", "io/mpi/"),
    "apps/": ("core/", "parallel/", "io/serial/", "io/mpi/", "apps/"),
}
MPI_FREE = ("core/", "io/serial/")
INCLUDE = re.compile(r'^\s*#\s*include\s*([<"])([^>"]+)[>"]')


def floor_of(path):
    for f in ALLOWED:
        if path.startswith(f):
            return f
    return None


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    root = sys.argv[1]
    bad, read = [], 0
    for top in ("core", "parallel", "io", "apps"):
        for d, _, names in os.walk(os.path.join(root, top)):
            for n in sorted(names):
                if not n.endswith((".cpp", ".hpp")):
                    continue
                rel = os.path.relpath(os.path.join(d, n), root).replace(os.sep, "/")
                floor = floor_of(rel)
                if floor is None:
                    bad.append(f"{rel}: in no floor of tests/check_floors.py")
                    continue
                read += 1
                with open(os.path.join(d, n), encoding="utf-8") as f:
                    for line_no, line in enumerate(f, 1):
                        m = INCLUDE.match(line)
                        if not m:
                            continue
                        kind, target = m.groups()
                        if kind == "<":
                            if floor in MPI_FREE and target.split("/")[0] in ("mpi.h", "hdf5.h"):
                                bad.append(f"{rel}:{line_no}: <{target}> in an MPI-free floor ({floor})")
                            continue
                        if "/" not in target:
                            continue  # a generated file of its own folder (demo_scene.inc)
                        if not target.startswith(ALLOWED[floor]) and floor_of(target) is not None:
                            bad.append(f"{rel}:{line_no}: includes {target}, above its floor {floor}")
                        elif floor_of(target) is None and not target.startswith(ALLOWED[floor]):
                            bad.append(f"{rel}:{line_no}: includes {target}, in no floor")
    for b in bad:
        print(b)
    print(f"{read} files read, {len(bad)} includes against the floors")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
