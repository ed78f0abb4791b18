#!/usr/bin/env python3
"""The contact model a run used, as run.h5 records it (the scene dataset's law.* attributes,
written from core/contact/params.hpp's one field list) and as report.html names it.
Usage: check_model_record.py OUT MODEL_NAME MODEL_NUMBER POISSON_RATIO"""
import sys

try:
    import h5py
except ImportError:
    print("h5py missing for", sys.executable, "(Debian: python3-h5py)")
    sys.exit(77)

out, name, number, nu = sys.argv[1], sys.argv[2], int(sys.argv[3]), float(sys.argv[4])
with h5py.File(f"{out}/run.h5", "r") as f:
    a = f["scene"].attrs
    got = a["law.model_name"]
    got = got.decode() if isinstance(got, bytes) else str(got)
    checks = {"law.model_name": (got, name), "law.model": (int(a["law.model"]), number),
              "law.poisson_ratio": (float(a["law.poisson_ratio"]), nu)}
bad = {k: v for k, v in checks.items() if v[0] != v[1]}
for k, (g, w) in checks.items():
    print(f"{k}: {g} (expected {w})")
with open(f"{out}/report.html") as f:
    if name not in f.read():
        bad["report.html"] = ("no", name)
        print(f"report.html does not name the model {name}")
sys.exit(1 if bad else 0)
