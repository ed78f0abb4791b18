#!/usr/bin/python3
"""Compares two CSV files cell by cell: the same header and shape, text cells equal, numbers equal
to a relative tolerance (sums over ranks in another order round differently), the columns named
by --skip (wall-clock) left out.
    same_numbers.py A.csv B.csv [--rel 1e-8] [--skip wall_seconds,...]
Exit 0 when they agree, 1 (with the first differences) when not."""
import argparse
import csv
import sys


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--rel", type=float, default=1e-8)
    ap.add_argument("--skip", default="wall_seconds")
    args = ap.parse_args()
    skip = set(filter(None, args.skip.split(",")))
    with open(args.a, newline="") as fa, open(args.b, newline="") as fb:
        ra, rb = list(csv.reader(fa)), list(csv.reader(fb))
    if not ra or ra[0] != rb[0]:
        print(f"DIFFERS: {args.a} {args.b}: headers")
        return 1
    if len(ra) != len(rb):
        print(f"DIFFERS: {args.a} {args.b}: {len(ra)} vs {len(rb)} rows")
        return 1
    head, bad, rounded = ra[0], 0, 0
    for n, (x, y) in enumerate(zip(ra[1:], rb[1:]), start=1):
        for col, u, v in zip(head, x, y):
            if col in skip or u == v:
                continue
            try:
                fu, fv = float(u), float(v)
            except ValueError:
                fu = fv = None
            if fu is None or abs(fu - fv) > args.rel * (abs(fu) + abs(fv)) + 1e-300:
                if bad < 5:
                    print(f"DIFFERS: {args.a}: row {n}, {col}: {u} vs {v}")
                bad += 1
            else:
                rounded += 1
    if bad:
        return 1
    print(f"same: {args.a} and {args.b}: {len(ra) - 1} rows ({rounded} values equal to rounding, relative < {args.rel})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
