#!/usr/bin/env python3
"""check_equilibration.py FABRICA SCENE WORKDIR: the three [triaxial] equilibration protocols
(docs/triaxial.md, "Equilibration protocols") on a sweep over mu_r = 0 and 0.2, compared with one
another and with what each promises:

- "case": the mu_r = 0.2 case is re-equilibrated with rolling resistance
  (e_rolling > 0 in its equilibration rows);
- "common": both cases' equilibration rows are identical, character for character, to the "case"
  run's mu_r = 0 case (re-equilibrated at mu_r = 0, without rolling energy); the mu_r = 0 case's
  shear rows are those of the "case" run; the mu_r = 0.2 case stores rolling energy from its first
  shear row on and its shear departs from the mu_r = 0 one. The re-equilibration runs once (the
  log says the mu_r = 0.2 case shares the mu_r = 0 case's) and the mu_r = 0.2 case shears from a
  copy of its end state: every file of that case (series, fabric rows) equals, character for
  character, those of a "common" run of the mu_r = 0.2 case alone, which re-equilibrates itself;
  the "common" runs write the fabric rows and run.h5 (with h5py: the mu_r = 0.2 case's snapshots of the
  re-equilibration are the mu_r = 0 case's groups, stored once, and its snapshots and series
  equal the single-case run's);
- "none": no equilibration rows; every case's shear starts from the consolidated state: at its
  first row (one output interval in) the void ratio is within 2 % of the consolidated one, while
  the re-equilibrated specimens of "case" start below it.
Every run exits 0 and writes summary.csv with one row per case."""
import csv
import os
import subprocess
import sys

fabrica, scene, work = sys.argv[1:4]
os.makedirs(work, exist_ok=True)
failures = []


def check(ok, what):
    print(("ok: " if ok else "FAILED: ") + what)
    if not ok:
        failures.append(what)


def run(mode, only=None):
    """The scene under 'mode'; 'only' = a single value of mu_r for the sweep (named mode_alone)."""
    label = mode if only is None else f"{mode}_alone"
    path = os.path.join(work, f"{label}.toml")
    with open(scene) as f, open(path, "w") as g:
        text = f.read()
        if mode == "common":  # run.h5 and the fabric rows too, snapshots within the re-equilibration
            text = text.replace("hdf5 = false", "hdf5 = true\nsnapshot_every = 400")
            text = text.replace("[fabric]\nenabled = false", "[fabric]\nenabled = true")
        if only is not None:
            text = text.replace("rolling_friction_cases = [0.0, 0.2]", f"rolling_friction_cases = [{only}]")
        g.write(text + f'equilibration = "{mode}"\n')
    out = os.path.join(work, label)
    r = subprocess.run([fabrica, "run", path, "-o", out, "--overwrite"], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{label}: fabrica run exited {r.returncode}:\n{r.stdout}\n{r.stderr}")
    names = ("mur_0", "mur_0.2") if only is None else (f"mur_{only}",)
    with open(os.path.join(out, "summary.csv")) as f:
        check(len(list(csv.DictReader(f))) == len(names), f"{label}: summary.csv has a row per case")
    cases = {}
    for name in names:
        with open(os.path.join(out, name, "series.csv")) as f:
            lines = f.read().splitlines()
        header = lines[0].split(",")
        rows = [dict(zip(header, l.split(","))) | {"line": l} for l in lines[1:]]
        cases[name] = {st: [r for r in rows if r["stage"] == st] for st in ("equilibration", "shear")}
    with open(os.path.join(out, "consolidation.csv")) as f:
        cons = list(csv.DictReader(f))
    return cases, float(cons[-1]["void_ratio"]), r.stdout


def lines(rows):
    return [r["line"] for r in rows]


case, e_cons, _ = run("case")
common, e_cons_common, log_common = run("common")
none, e_cons_none, log_none = run("none")

check(all(float(r["e_rolling"]) > 0 for r in case["mur_0.2"]["equilibration"]),
      "case: the mu_r = 0.2 case is re-equilibrated with rolling resistance (e_rolling > 0 at every row)")
check(lines(common["mur_0"]["equilibration"]) == lines(case["mur_0"]["equilibration"]) and
      lines(common["mur_0.2"]["equilibration"]) == lines(case["mur_0"]["equilibration"]),
      f"common: both cases' {len(case['mur_0']['equilibration'])} equilibration rows equal the case "
      "run's mu_r = 0 rows")
check(lines(common["mur_0"]["shear"]) == lines(case["mur_0"]["shear"]),
      "common: the mu_r = 0 case's shear rows equal the case run's")
check(all(float(r["e_rolling"]) > 0 for r in common["mur_0.2"]["shear"]),
      "common: the mu_r = 0.2 case stores rolling energy at every shear row")
check(lines(common["mur_0.2"]["shear"]) != lines(common["mur_0"]["shear"]),
      "common: the mu_r = 0.2 shear departs from the mu_r = 0 one")
check("equilibrated in" in log_common and "(mu_r = 0," in log_common,
      "common: the log says the re-equilibration is at mu_r = 0")
check("case mur_0.2: equilibrated in" in log_common and "the re-equilibration of case mur_0;" in log_common,
      "common: the log says the mu_r = 0.2 case shares the mu_r = 0 case's re-equilibration")
alone, _, log_alone = run("common", only=0.2)
check("the re-equilibration of case" not in log_alone, "common, mu_r = 0.2 alone: re-equilibrated by itself")
for name in ("series.csv", "fabric.csv", "sff.csv", "rose.csv"):
    a, b = (os.path.join(work, d, "mur_0.2", name) for d in ("common", "common_alone"))
    with open(a) as f, open(b) as g:
        check(f.read() == g.read(), f"common: mur_0.2/{name} equals the single-case run's, character for character")
try:
    import h5py
except ImportError:
    h5py = None
    print("skipped: run.h5 of the common runs (no h5py)")
if h5py:
    with h5py.File(os.path.join(work, "common", "run.h5"), "r") as f, \
         h5py.File(os.path.join(work, "common_alone", "run.h5"), "r") as g:
        eq_steps = [int(r["step"]) for r in common["mur_0.2"]["equilibration"]]
        shared = [k for k in f["snapshots/mur_0.2"] if int(k) <= eq_steps[-1]]
        check(len(shared) >= 2 and all(f[f"snapshots/mur_0.2/{k}"] == f[f"snapshots/mur_0/{k}"] for k in shared),
              f"common: the mu_r = 0.2 case's {len(shared)} snapshots of the re-equilibration are the mu_r = 0 "
              "case's groups (HDF5 hard links)")
        same = sorted(f["snapshots/mur_0.2"]) == sorted(g["snapshots/mur_0.2"])
        for k in g["snapshots/mur_0.2"] if same else []:
            for part in ("particles", "contacts"):
                for d in g[f"snapshots/mur_0.2/{k}/{part}"]:
                    same = same and (f[f"snapshots/mur_0.2/{k}/{part}/{d}"][()] == g[f"snapshots/mur_0.2/{k}/{part}/{d}"][()]).all()
        for c in g["series/mur_0.2"]:
            same = same and (f[f"series/mur_0.2/{c}"][()] == g[f"series/mur_0.2/{c}"][()]).all()
        check(same, f"common: the mu_r = 0.2 case's {len(g['snapshots/mur_0.2'])} snapshots and its series in run.h5 "
              "equal the single-case run's, bit for bit")
check(all(not none[c]["equilibration"] for c in none), "none: no equilibration rows")
check(e_cons_none == e_cons_common == e_cons, "the consolidation is the same in the three runs")
for c in ("mur_0", "mur_0.2"):
    e0 = float(none[c]["shear"][0]["void_ratio"])
    check(abs(e0 - e_cons) <= 0.02 * e_cons,
          f"none, {c}: first shear row void ratio {e0:.4f} within 2 % of the consolidated {e_cons:.4f}")
e_case = float(case["mur_0"]["equilibration"][-1]["void_ratio"])
check(e_case < e_cons, f"case: re-equilibration at mu_s = 0.3 densifies the specimen ({e_cons:.4f} -> {e_case:.4f})")
check("not re-equilibrated" in log_none, "none: the log says the cases are not re-equilibrated")
sys.exit(1 if failures else 0)
