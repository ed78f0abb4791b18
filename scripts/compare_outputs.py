#!/usr/bin/python3
"""Two output directories of Fabrica compared bit for bit: a check for changes that must not
change results (a refactoring, a faster kernel), docs/design.md "Changing the code".

    /usr/bin/python3 scripts/compare_outputs.py OUT_BEFORE OUT_AFTER

Every CSV file present in both is compared cell by cell, except the columns that hold measured
times (wall-clock seconds, per-step timings), which differ from one run to the next; every dataset
of run.h5 present in both is compared value by value (bytes, so NaN == NaN), except the attributes
that name the build (fabrica_version, git_describe) and the run's wall-clock times. Files or datasets
that only one side has are listed. Exit 0 when everything compared is the same, 1 otherwise.
"""
import csv
import os
import sys

TIME_WORDS = ("wall", "seconds_run", "elapsed", "time_s", "_ms", "timing", "us_per")


def timed(column):
    c = column.lower()
    return any(w in c for w in TIME_WORDS)


def files_under(root, suffix):
    out = set()
    for d, _, names in os.walk(root):
        for n in names:
            if n.endswith(suffix):
                out.add(os.path.relpath(os.path.join(d, n), root))
    return out


def compare_csv(a, b, name, problems):
    with open(a, newline="") as fa, open(b, newline="") as fb:
        ra, rb = list(csv.reader(fa)), list(csv.reader(fb))
    if not ra or not rb:
        if ra != rb:
            problems.append(f"{name}: one side empty")
        return 0
    header = ra[0]
    if header != rb[0]:
        problems.append(f"{name}: headers differ")
        return 0
    if len(ra) != len(rb):
        problems.append(f"{name}: {len(ra) - 1} rows against {len(rb) - 1}")
    skip = {i for i, h in enumerate(header) if timed(h)}
    cells = 0
    for r, (x, y) in enumerate(zip(ra[1:], rb[1:]), start=2):
        for i, (u, v) in enumerate(zip(x, y)):
            if i in skip:
                continue
            cells += 1
            if u != v:
                problems.append(f"{name} line {r} column {header[i] if i < len(header) else i}: {u} against {v}")
                return cells
    return cells


def compare_h5(a, b, name, problems):
    import h5py
    import numpy as np

    seen = {}

    def collect(f):
        items = {}

        def visit(path, obj):
            if isinstance(obj, h5py.Dataset):
                items[path] = obj

        f.visititems(visit)
        return items

    count = 0
    with h5py.File(a, "r") as fa, h5py.File(b, "r") as fb:
        da, db = collect(fa), collect(fb)
        for path in sorted(set(da) ^ set(db)):
            problems.append(f"{name}:{path} only in {'the first' if path in da else 'the second'}")
        for path in sorted(set(da) & set(db)):
            x, y = da[path][()], db[path][()]
            count += 1
            if isinstance(x, np.ndarray):
                same = x.shape == y.shape and x.dtype == y.dtype and x.tobytes() == y.tobytes()
            else:
                same = x == y
            if not same:
                problems.append(f"{name}:{path} differs")
    return count


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    a, b = sys.argv[1:]
    problems = []
    csv_a, csv_b = files_under(a, ".csv"), files_under(b, ".csv")
    for n in sorted(csv_a ^ csv_b):
        problems.append(f"{n} only in {'the first' if n in csv_a else 'the second'}")
    cells = sum(compare_csv(os.path.join(a, n), os.path.join(b, n), n, problems) for n in sorted(csv_a & csv_b))
    h5_a, h5_b = files_under(a, ".h5"), files_under(b, ".h5")
    datasets = 0
    for n in sorted(h5_a & h5_b):
        datasets += compare_h5(os.path.join(a, n), os.path.join(b, n), n, problems)
    for p in problems[:40]:
        print(p)
    print(f"{len(csv_a & csv_b)} CSV files ({cells} cells), {datasets} HDF5 datasets compared: "
          f"{'the same' if not problems else str(len(problems)) + ' differences'}")
    sys.exit(1 if problems else 0)


if __name__ == "__main__":
    main()
