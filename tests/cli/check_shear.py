#!/usr/bin/python3
"""Checks the output of the shear examples (docs/shear.md) for the cli tests:

    check_shear.py simple OUT    examples/simple_shear.toml: drained simple shear to gamma 0.3
    check_shear.py cyclic OUT    examples/cyclic_simple_shear.toml: constant volume, a loss of p

Common to both: the shear columns of the series (gamma_ij, sigma_1 >= sigma_2 >= sigma_3 summing
to s11 + s22 + s33, a unit major direction n whose angle theta_12 lies in (-90, 90]), those of
stages.csv, and fabric.csv's non-coaxiality in [0, 90] and deviatoric anisotropy tensors'
principal values (descending, summing to zero). Exit status 1 with the failed checks listed.
"""
import csv
import math
import sys

failures = []


def check(ok, what):
    if not ok:
        failures.append(what)


def rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def num(r, k):
    return float(r[k])


def common(out, stage):
    series = [r for r in rows(f"{out}/series.csv") if r["stage"] == stage]
    check(len(series) > 10, f"series.csv: {len(series)} rows of stage {stage}")
    for r in series:
        s = [num(r, "sigma_1"), num(r, "sigma_2"), num(r, "sigma_3")]
        trace = num(r, "s11") + num(r, "s22") + num(r, "s33")
        check(s[0] >= s[1] >= s[2], f"step {r['step']}: principal stresses not descending {s}")
        check(abs(sum(s) - trace) <= 1e-6 * max(1.0, abs(trace)), f"step {r['step']}: sum of sigma {sum(s)} != {trace}")
        n = [num(r, "n1"), num(r, "n2"), num(r, "n3")]
        check(abs(math.hypot(*n) - 1) < 1e-9, f"step {r['step']}: |n| = {math.hypot(*n)}")
        t = num(r, "theta_12")
        check(math.isnan(t) or -90 < t <= 90, f"step {r['step']}: theta_12 = {t}")
        check(num(r, "gamma_13") == 0 and num(r, "gamma_23") == 0, f"step {r['step']}: gamma_13, gamma_23 not 0")
    summary = [r for r in rows(f"{out}/stages.csv") if r["name"] == stage]
    check(len(summary) == 1 and "gamma_12" in summary[0], f"stages.csv: no row with gamma_12 for {stage}")
    fabric = [r for r in rows(f"{out}/fabric.csv") if r["stage"] == stage]
    check(len(fabric) > 10, f"fabric.csv: {len(fabric)} rows of stage {stage}")
    for r in fabric:
        a = num(r, "noncoaxiality")
        if math.isnan(a):
            continue
        check(0 <= a <= 90, f"fabric.csv step {r['step']} {r['network']}: noncoaxiality {a}")
        for t in ("ac", "an"):
            v = [num(r, f"{t}_{k}") for k in (1, 2, 3)]
            check(v[0] >= v[1] >= v[2] and abs(sum(v)) < 1e-9 * max(1.0, abs(v[0])),
                  f"fabric.csv step {r['step']} {r['network']}: {t} principal values {v}")
    return series, summary[0] if summary else {}


def simple(out):
    series, summary = common(out, "simple_shear")
    last = series[-1]
    g = num(last, "gamma_12")
    check(0.3 <= g < 0.301, f"the stage ended at gamma_12 = {g}, not just past 0.3")
    check(abs(num(last, "s11") - 100e3) < 0.05 * 100e3, f"s11 = {num(last, 's11')} not held at 100 kPa")
    check(num(last, "eps2") == 0 and num(last, "eps3") == 0, "the lateral axes moved")
    tau = -num(last, "s12")
    check(0.1 * 100e3 < tau < 1.0 * 100e3, f"tau at the end {tau} Pa: not a sheared granular specimen's")
    check(-70 < num(last, "theta_12") < -20, f"the major stress at {num(last, 'theta_12')} degrees, not near -45")
    check(abs(num(summary, "gamma_12") - g) < 1e-12, "stages.csv's gamma_12 is not the series' last")
    print(f"simple shear: gamma_12 {g:.4f}, tau {tau / 1e3:.2f} kPa, s11 {num(last, 's11') / 1e3:.2f} kPa, "
          f"theta_12 {num(last, 'theta_12'):.1f} degrees, tau / s11 {tau / num(last, 's11'):.3f}")


def cyclic(out):
    series, _ = common(out, "cyclic")
    p0 = num(series[0], "p")
    for r in series:
        check(abs(num(r, "epsv")) < 1e-9, f"step {r['step']}: the volume changed, epsv {num(r, 'epsv')}")
    taus = [-num(r, "s12") for r in series]
    check(max(taus) > 0.9 * 15e3 and min(taus) < -0.9 * 15e3, f"tau in [{min(taus)}, {max(taus)}]: not +-15 kPa")
    p_end = num(series[-1], "p")
    check(p_end < 0.5 * p0, f"p from {p0} to {p_end}: no loss of p")
    print(f"cyclic simple shear: p {p0 / 1e3:.1f} -> {p_end / 1e3:.2f} kPa, tau in [{min(taus) / 1e3:.2f}, "
          f"{max(taus) / 1e3:.2f}] kPa, gamma_12 at the end {num(series[-1], 'gamma_12'):.4f}")


if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] not in ("simple", "cyclic"):
        sys.exit(__doc__)
    (simple if sys.argv[1] == "simple" else cyclic)(sys.argv[2])
    if failures:
        print("\n".join(failures[:20]))
        sys.exit(1)
    print("ok")
