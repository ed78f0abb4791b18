#!/usr/bin/python3
"""Checks the servo at 10^5 spheres (tests/cli/servo_large.sh) from the run's CSV files.

    /usr/bin/python3 check_servo_large.py OUT TARGET

OUT/series.csv: the consolidation stage's last row within 0.5 % of TARGET on every axis with an
unbalanced-force ratio below 1e-4 (its end condition, at_rest, with stress_tolerance 0.005 and
unbalanced_tolerance 1e-4), and every shear row's lateral stresses s22, s33 within 1 % of TARGET;
OUT/stages.csv: both stages finished, the shear's own largest stress error below 1 %.
Standard library only.
"""
import csv
import sys


def main():
    out, target = sys.argv[1], float(sys.argv[2])
    with open(f"{out}/series.csv") as f:
        rows = list(csv.DictReader(f))
    with open(f"{out}/stages.csv") as f:
        stages = list(csv.DictReader(f))
    bad = []
    cons = [r for r in rows if r["stage"] == "consolidate"]
    shear = [r for r in rows if r["stage"] == "shear"]
    if not cons or not shear:
        sys.exit(f"check_servo_large.py: {out}/series.csv: {len(cons)} consolidation and {len(shear)} shear rows")
    last = cons[-1]
    for s in ("s11", "s22", "s33"):
        err = abs(float(last[s]) - target) / target
        if err > 0.005:
            bad.append(f"consolidated {s} = {last[s]} Pa: {100 * err:.3f} % from {target:g} Pa (limit 0.5 %)")
    if float(last["unbalanced"]) >= 1e-4:
        bad.append(f"consolidated with unbalanced-force ratio {last['unbalanced']} (limit 1e-4)")
    lateral = max(abs(float(r[s]) - target) / target for r in shear for s in ("s22", "s33"))
    if lateral >= 0.01:
        bad.append(f"lateral stress error in shear {100 * lateral:.4f} % (limit 1 %)")
    names = [st["name"] for st in stages]
    if names != ["consolidate", "shear"]:
        bad.append(f"stages.csv lists {names}, not [consolidate, shear]")
    elif float(stages[1]["max_stress_error"]) >= 0.01:
        bad.append(f"stages.csv: shear max_stress_error {stages[1]['max_stress_error']} (limit 0.01)")
    print(f"{out}: consolidated in {stages[0]['steps'] if stages else '?'} steps to "
          f"({last['s11']}, {last['s22']}, {last['s33']}) Pa, unbalanced {last['unbalanced']}; "
          f"shear {len(shear)} rows to eps1 = {shear[-1]['eps1']}, lateral error <= {100 * lateral:.4f} %")
    if bad:
        sys.exit("check_servo_large.py: " + "; ".join(bad))


if __name__ == "__main__":
    main()
