#!/usr/bin/python3
"""The exact stress shares of the sub-networks in a triaxial run's output (docs/fabric.md, "Each
network's share of the stress"): for every analysed instant (each row of sff.csv of every case
and of the consolidation) and each of the six partitions,

- the networks' p_k (fabric.csv) add up to p (sff.csv), within 2e-9 of p;
- the sum of their full stress tensors (s11_k ... s31_k) is the tensor of the row of 'all',
  within 1e-8 of p per component, and its q is q (sff.csv), within 1e-8 of p;
- their shares (fabric.csv 'share') add up to 1 within 1e-8, and each is p_k / p within 1e-8;
- q_p_exact of the partition is (2/5) sum_k share_k (a_c + a_b + a_n + 3/2 a_t) of its
  networks' rows, within 1e-8 of q/p;
- for the partition 'all': q_p_exact = q_p_star (the same weight, 1) and q_p_recombined = q/p.

Every value is written with 10 significant digits (relative rounding 5e-10 at most), hence
the tolerances: 2e-9 for a sum of up to four non-negative p_k, 1e-8 where components of either
sign or products enter. A share other than p_k / p (xi, say: 5-20 % off in these runs) or a
network left out of a sum fails by orders of magnitude more.

    check_sff_shares.py RUN_DIR
"""
import os
import sys

import numpy as np

PARTITIONS = {"all": ["all"], "ns_s": ["ns", "s"], "sf_wf": ["sf", "wf"], "nr_r": ["nr", "r"],
              "ns_s_nr_r": ["ns-nr", "ns-r", "s-nr", "s-r"],
              "ns_s_sf_wf": ["ns-sf", "ns-wf", "s-sf", "s-wf"]}
COMPONENTS = ["s11_k", "s12_k", "s13_k", "s21_k", "s22_k", "s23_k", "s31_k", "s32_k", "s33_k"]
failures = []


def check(ok, what):
    if not ok:
        failures.append(what)


def table(path):
    return np.atleast_1d(np.genfromtxt(path, delimiter=",", names=True, dtype=None, encoding="utf-8"))


def tensor(row):
    return np.array([float(row[c]) for c in COMPONENTS]).reshape(3, 3)


def p_q(s):
    p = np.trace(s) / 3
    d = s - p * np.eye(3)
    return p, np.sqrt(1.5 * np.sum(d * d))


def check_case(label, fabric, sff):
    worst = {"p": 0.0, "sigma": 0.0, "q": 0.0, "share": 0.0, "exact": 0.0}
    rows = 0
    for r in sff:
        step, p, q, qp = int(r["step"]), float(r["p"]), float(r["q"]), float(r["q_p"])
        if not p > 0:
            continue
        rows += 1
        nets = {str(f["network"]): f for f in fabric[fabric["step"] == step]}
        check(len(nets) == 15, f"{label} step {step}: {len(nets)} network rows, not 15")
        whole = tensor(nets["all"])
        for part, members in PARTITIONS.items():
            where = f"{label} step {step} partition {part}"
            p_sum, s_sum, share, exact = 0.0, np.zeros((3, 3)), 0.0, 0.0
            for n in members:
                f = nets[n]
                if int(f["count"]) == 0:
                    check(float(f["share"]) == 0.0, f"{where}: empty {n} has share {f['share']}")
                    continue
                p_sum += float(f["p_k"])
                s_sum += tensor(f)
                share += float(f["share"])
                e = abs(float(f["share"]) - float(f["p_k"]) / p)
                worst["share"] = max(worst["share"], e)
                check(e < 1e-8, f"{where}: share of {n} {f['share']} is not p_k / p = {float(f['p_k']) / p}")
                exact += 0.4 * float(f["share"]) * (f["a_c"] + f["a_b"] + f["a_n"] + 1.5 * f["a_t"])
            e_p = abs(p_sum - p) / p
            e_sigma = np.abs(s_sum - whole).max() / p
            e_q = abs(p_q(s_sum)[1] - q) / p
            e_share = abs(share - 1)
            e_exact = abs(exact - float(r["q_p_exact_" + part])) / qp
            for k, v in (("p", e_p), ("sigma", e_sigma), ("q", e_q), ("share", e_share), ("exact", e_exact)):
                worst[k] = max(worst[k], v)
            check(e_p < 2e-9, f"{where}: sum of p_k {p_sum} against p {p} ({e_p:.1e} of p)")
            check(e_sigma < 1e-8, f"{where}: sum of the networks' stresses differs from all's by {e_sigma:.1e} of p")
            check(e_q < 1e-8, f"{where}: q of the summed stresses {p_q(s_sum)[1]} against q {q} ({e_q:.1e} of p)")
            check(e_share < 1e-8, f"{where}: shares add up to {share}")
            check(e_exact < 1e-8, f"{where}: q_p_exact {r['q_p_exact_' + part]} against {exact} from fabric.csv")
        check(r["q_p_exact_all"] == r["q_p_star_all"], f"{label} step {step}: q_p_exact_all != q_p_star_all")
        check(abs(r["q_p_recombined_all"] - qp) <= 1e-9 * qp, f"{label} step {step}: q_p_recombined_all != q_p")
    check(rows > 0, f"{label}: no row with p > 0")
    print(f"{label}: {rows} rows; largest deviations over the six partitions: sum p_k - p {worst['p']:.1e} of p, "
          f"summed tensor {worst['sigma']:.1e} of p, its q {worst['q']:.1e} of p, shares - p_k / p "
          f"{worst['share']:.1e}, q_p_exact against fabric.csv {worst['exact']:.1e} of q/p")


def main():
    run = sys.argv[1]
    cases = [("consolidation", os.path.join(run, "consolidation_fabric.csv"), os.path.join(run, "consolidation_sff.csv"))]
    cases += [(d, os.path.join(run, d, "fabric.csv"), os.path.join(run, d, "sff.csv"))
              for d in sorted(os.listdir(run)) if os.path.isfile(os.path.join(run, d, "sff.csv"))]
    for label, fab, sff in cases:
        if not os.path.isfile(sff):
            failures.append(f"{sff}: missing")
            continue
        check_case(label, table(fab), table(sff))
    check(len(cases) >= 3, f"{run}: {len(cases)} analysed stages, expected the consolidation and two cases")
    for f in failures[:20]:
        print("FAILED:", f)
    if failures:
        sys.exit(f"{len(failures)} check(s) failed")
    print("the networks' stress shares add up to the global stress in every partition and row")


if __name__ == "__main__":
    main()
