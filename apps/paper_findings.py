"""The twelve findings of the reference study (shared/spec/reference-problem.md section 7),
each decided on a run's output with stated numbers and thresholds (docs/fabric.md, "The study's
findings, decided by the report", lists the criteria).

``decide(run)`` returns twelve :class:`Finding`, in the spec's order. A verdict is
``holds``, ``does not hold``, or ``cannot be decided`` when the run lacks what the finding is
about (a single mu_r for a trend in mu_r, a single consolidation mu_s for item 12, an empty
network). Fabric values are means over the residual state (eps_1 >= 0.6 x the final eps_1) of
the reference case (mu_r nearest 0.05, among mu_r > 0) unless the criterion says otherwise.
"""
from dataclasses import dataclass

import numpy as np

import paper_data as pd

HOLDS, FAILS, UNDECIDED = "holds", "does not hold", "cannot be decided"

# Thresholds of the criteria (fabric components are shares of contacts, 1/3 = isotropic).
ISOTROPIC_TOL = 0.03   # "nearly isotropic": every phi_ii within this of 1/3
ANISOTROPIC = 0.05     # "clearly anisotropic along axis 1": phi_11 above 1/3 by more than this
RISE = 0.02            # item 1: phi_11 rises by more than this from the start of shear
STEADY = 0.01          # item 1: the two halves of the residual state differ by less than this
BARELY = 0.15          # "barely changes": (max - min) / mean over the cases below this
XI_STEADY = 0.02       # item 9: xi_sf varies by less than this over the cases
SFF_CLOSE = 0.05       # item 11: mean |(q/p)* - q/p| / (q/p) below this for every mu_r


@dataclass
class Finding:
    number: int
    statement: str  #: the study's statement (spec section 7)
    verdict: str    #: HOLDS, FAILS or UNDECIDED
    numbers: str    #: the values it was decided on
    criterion: str  #: how it was decided


STATEMENTS = [
    "Global phi_11 rises from 1/3 then eases to a steady value; phi_22, phi_33 fall then recover slightly.",
    "Non-sliding contacts are clearly anisotropic along the major principal direction; sliding contacts "
    "are nearly isotropic at the residual state, slightly concentrated along the minor one.",
    "ns-nr and ns-r fabrics look like the global one but more anisotropic; s-r stays near 1/3 in every "
    "direction; s-nr loses weight along axis 1 and gains laterally.",
    "Strong contacts are fewer than weak ones and more anisotropic than the whole, along axis 1; weak "
    "contacts are nearly isotropic at the residual state.",
    "ns-sf is the most anisotropic of {ns-sf, ns-wf, s-sf, s-wf}; s-wf leans toward the minor axis.",
    "a_c of ns, sf and ns-sf exceed the global a_c; the global a_n is the largest a_n.",
    "a_c of every network grows with mu_r.",
    "a_n and a_n^ns grow with mu_r and exceed a_c; a_n^sf and a_n^{ns-sf} barely change with mu_r.",
    "xi_ns and xi_{ns-sf} decrease with mu_r; xi_sf does not change with mu_r.",
    "Peak q/p grows with mu_r; dilatancy grows with mu_r.",
    "(q/p)* from the SFF relation is very close to the measured q/p for every mu_r.",
    "Initial void ratio after consolidation grows with the consolidation mu_s, more slowly at higher mu_s.",
]


def f3(x):
    return "nan" if not np.isfinite(x) else f"{x:.3f}"


def verdict(parts):
    """HOLDS if every (name, ok) part holds, else FAILS naming the parts that do not."""
    bad = [n for n, ok in parts if not ok]
    return HOLDS if not bad else FAILS, ("" if not bad else " Not met: " + "; ".join(bad) + ".")


def phis(case, net):
    return [case.res_mean(net, k) for k in ("phi11", "phi22", "phi33")]


def empty(case, net):
    s = case.net(net)
    return s.size == 0 or not np.isfinite(s["phi11"][case.residual(s)]).any()


def smooth(v, n=5):
    if v.size < n:
        return v
    return np.convolve(v, np.ones(n) / n, mode="valid")


def item1(run, ref):
    s = ref.net("all")
    res = ref.residual(s)
    e, p11 = s["eps1"], s["phi11"]
    start = p11[0]
    r = p11[res]
    half = r.size // 2
    rise = p11.max() - start
    drift = abs(r[half:].mean() - r[:half].mean()) if r.size >= 2 else float("nan")
    parts = [("phi_11 starts near 1/3", abs(start - 1 / 3) < ISOTROPIC_TOL),
             (f"phi_11 rises by more than {RISE}", rise > RISE),
             (f"phi_11 steady at the residual state (halves differ by < {STEADY})", drift < STEADY)]
    txt = (f"{ref.text}: phi_11 {f3(start)} at eps_1 = {100 * e[0]:.1f} %, largest {f3(p11.max())} "
           f"at {100 * e[np.argmax(p11)]:.1f} %, residual {f3(r.mean())} (halves differ by {f3(drift)})")
    for k in ("phi22", "phi33"):
        v = s[k]
        sm = smooth(v)
        off = (v.size - sm.size) // 2
        i = int(np.argmin(sm)) + off
        fall = v[0] - sm.min()
        recover = v[res].mean() - sm.min()
        early = e[i] < pd.RESIDUAL_FROM * e.max()
        parts += [(f"{k} falls", fall > 0.005), (f"{k} recovers after its minimum", early and recover > 0.002)]
        txt += (f"; {k} {f3(v[0])} -> smoothed minimum {f3(sm.min())} at {100 * e[i]:.1f} % -> residual "
                f"{f3(v[res].mean())}")
    v, why = verdict(parts)
    return v, txt + "." + why, (f"phi_11 starts within {ISOTROPIC_TOL} of 1/3, rises by > {RISE}, and the two halves of "
                                f"the residual state differ by < {STEADY}; phi_22, phi_33 fall by > 0.005 to a "
                                "minimum (5-row moving average) before the residual state and end > 0.002 above it")


def item2(run, ref):
    ns, s = phis(ref, "ns"), phis(ref, "s")
    parts = [(f"phi_11^ns above 1/3 by > {ANISOTROPIC}", ns[0] - 1 / 3 > ANISOTROPIC),
             (f"s within {ISOTROPIC_TOL} of 1/3", max(abs(x - 1 / 3) for x in s) < ISOTROPIC_TOL),
             ("s leans to a minor axis (phi_22^s or phi_33^s > phi_11^s)", max(s[1], s[2]) > s[0])]
    v, why = verdict(parts)
    return v, (f"{ref.text}, residual: ns phi_11/22/33 = {' / '.join(f3(x) for x in ns)}; "
               f"s = {' / '.join(f3(x) for x in s)}.{why}"), \
        f"phi_11^ns - 1/3 > {ANISOTROPIC}; every phi_ii^s within {ISOTROPIC_TOL} of 1/3; max(phi_22^s, phi_33^s) > phi_11^s"


def item3(run, ref):
    if any(empty(ref, n) for n in ("ns-nr", "s-nr")):
        return UNDECIDED, f"{ref.text}: ns-nr / s-nr are empty (with mu_r = 0 every contact rolls)", "needs mu_r > 0"
    g, nsnr, nsr, snr, sr = (phis(ref, n) for n in ("all", "ns-nr", "ns-r", "s-nr", "s-r"))
    parts = [("ns-nr more anisotropic than the global fabric", nsnr[0] > g[0] and nsnr[1] < g[1]),
             ("ns-r more anisotropic than the global fabric", nsr[0] > g[0] and nsr[1] < g[1]),
             (f"s-r within {ISOTROPIC_TOL} of 1/3", max(abs(x - 1 / 3) for x in sr) < ISOTROPIC_TOL),
             ("s-nr below 1/3 along axis 1 and above it laterally", snr[0] < 1 / 3 < min(snr[1], snr[2]))]
    v, why = verdict(parts)
    fmt = lambda p: " / ".join(f3(x) for x in p)  # noqa: E731
    return v, (f"{ref.text}, residual phi_11/22/33: global {fmt(g)}; ns-nr {fmt(nsnr)}; ns-r {fmt(nsr)}; "
               f"s-r {fmt(sr)}; s-nr {fmt(snr)}.{why}"), \
        (f"phi_11 of ns-nr and ns-r above, phi_22 below the global values; every phi_ii^s-r within {ISOTROPIC_TOL} "
         "of 1/3; phi_11^s-nr < 1/3 < phi_22^s-nr, phi_33^s-nr")


def item4(run, ref):
    nsf, nwf = ref.res_mean("sf", "count"), ref.res_mean("wf", "count")
    g, sf, wf = phis(ref, "all"), phis(ref, "sf"), phis(ref, "wf")
    parts = [("fewer strong than weak contacts", nsf < nwf),
             ("phi_11^sf above the global phi_11", sf[0] > g[0]),
             (f"wf within {ISOTROPIC_TOL} of 1/3", max(abs(x - 1 / 3) for x in wf) < ISOTROPIC_TOL)]
    v, why = verdict(parts)
    return v, (f"{ref.text}, residual: {nsf:.0f} strong against {nwf:.0f} weak contacts; phi_11 of sf "
               f"{f3(sf[0])} against global {f3(g[0])}; wf phi_11/22/33 = {' / '.join(f3(x) for x in wf)}.{why}"), \
        f"mean count of sf < wf; phi_11^sf > phi_11; every phi_ii^wf within {ISOTROPIC_TOL} of 1/3"


def item5(run, ref):
    nets = ["ns-sf", "ns-wf", "s-sf", "s-wf"]
    ac = {n: ref.res_mean(n, "a_c") for n in nets}
    parts = [("ns-sf has the largest a_c of the four", all(ac["ns-sf"] > ac[n] for n in nets[1:])),
             ("a_c^s-wf < 0 (towards the minor axes)", ac["s-wf"] < 0)]
    v, why = verdict(parts)
    return v, f"{ref.text}, residual a_c: " + ", ".join(f"{n} {f3(ac[n])}" for n in nets) + "." + why, \
        "a_c^ns-sf above the other three; the signed index a_c^s-wf negative"


def item6(run, ref):
    ac = {n: ref.res_mean(n, "a_c") for n in ("all", "ns", "sf", "ns-sf")}
    an = {n: ref.res_mean(n, "a_n") for n in pd.NETWORKS}
    an = {n: x for n, x in an.items() if np.isfinite(x)}
    top = max(an, key=an.get)
    parts = [("a_c of ns, sf, ns-sf above the global a_c", all(ac[n] > ac["all"] for n in ("ns", "sf", "ns-sf"))),
             (f"the global a_n the largest (largest: {top})", top == "all")]
    others = sorted(((x, n) for n, x in an.items() if n != "all"), reverse=True)[:2]
    v, why = verdict(parts)
    return v, (f"{ref.text}, residual a_c: global {f3(ac['all'])}, ns {f3(ac['ns'])}, sf {f3(ac['sf'])}, "
               f"ns-sf {f3(ac['ns-sf'])}; a_n: global {f3(an.get('all', np.nan))}, next "
               + ", ".join(f"{n} {f3(x)}" for x, n in others) + "." + why), \
        "residual means; a_n compared over the networks where it is defined (min_weight > 0)"


def trend(run, net, key):
    return [c.res_mean(net, key) for c in run.cases]


def increasing(v):
    return all(b > a for a, b in zip(v, v[1:]))


def decreasing(v):
    return all(b < a for a, b in zip(v, v[1:]))


def murs(run):
    return "mu_r = " + " / ".join(f"{c.mu_r:g}" for c in run.cases)


def needs_sweep(run):
    return len({c.mu_r for c in run.cases}) < 2


def item7(run, ref):
    if needs_sweep(run):
        return UNDECIDED, "one mu_r only", "needs two values of mu_r or more"
    grow, lines = [], []
    for n in pd.NETWORKS:
        v = trend(run, n, "a_c")
        if not all(np.isfinite(v)):
            continue
        grow.append((n, increasing(v)))
        if n in ("all", "ns", "sf", "ns-sf") or not increasing(v):
            lines.append(f"{n} " + " -> ".join(f3(x) for x in v))
    ok = sum(g for _, g in grow)
    v = HOLDS if ok == len(grow) else FAILS
    return v, (f"{murs(run)}: a_c grows in {ok} of the {len(grow)} networks defined in every case; "
               + "; ".join(lines) + "."), \
        "residual mean of a_c strictly increasing in mu_r, for every network non-empty in every case"


def spread(v):
    v = np.asarray(v, float)
    return (v.max() - v.min()) / abs(v.mean()) if v.size and v.mean() != 0 else float("nan")


def item8(run, ref):
    if needs_sweep(run):
        return UNDECIDED, "one mu_r only", "needs two values of mu_r or more"
    an, anns = trend(run, "all", "a_n"), trend(run, "ns", "a_n")
    ac, acns = trend(run, "all", "a_c"), trend(run, "ns", "a_c")
    ansf, annssf = trend(run, "sf", "a_n"), trend(run, "ns-sf", "a_n")
    parts = [("a_n grows", increasing(an)), ("a_n^ns grows", increasing(anns)),
             ("a_n > a_c and a_n^ns > a_c^ns in every case",
              all(a > b for a, b in zip(an, ac)) and all(a > b for a, b in zip(anns, acns))),
             (f"a_n^sf barely changes (spread < {BARELY:.0%})", spread(ansf) < BARELY),
             (f"a_n^ns-sf barely changes (spread < {BARELY:.0%})", spread(annssf) < BARELY)]
    v, why = verdict(parts)
    j = lambda v: " -> ".join(f3(x) for x in v)  # noqa: E731
    return v, (f"{murs(run)}: a_n {j(an)} (a_c {j(ac)}); a_n^ns {j(anns)} (a_c^ns {j(acns)}); "
               f"a_n^sf {j(ansf)} (spread {spread(ansf):.0%}); a_n^ns-sf {j(annssf)} "
               f"(spread {spread(annssf):.0%}; rows with min_weight <= 0 left out).{why}"), \
        f"residual means strictly increasing; 'barely changes': (max - min) / mean < {BARELY:.0%}"


def item9(run, ref):
    if needs_sweep(run):
        return UNDECIDED, "one mu_r only", "needs two values of mu_r or more"
    xns, xnssf, xsf = trend(run, "ns", "xi"), trend(run, "ns-sf", "xi"), trend(run, "sf", "xi")
    parts = [("xi_ns decreases", decreasing(xns)), ("xi_ns-sf decreases", decreasing(xnssf)),
             (f"xi_sf varies by < {XI_STEADY}", max(xsf) - min(xsf) < XI_STEADY)]
    v, why = verdict(parts)
    j = lambda v: " -> ".join(f3(x) for x in v)  # noqa: E731
    return v, f"{murs(run)}, residual: xi_ns {j(xns)}; xi_ns-sf {j(xnssf)}; xi_sf {j(xsf)}.{why}", \
        f"residual means strictly decreasing; xi_sf: max - min < {XI_STEADY}"


def item10(run, ref):
    if needs_sweep(run):
        return UNDECIDED, "one mu_r only", "needs two values of mu_r or more"
    peak = [float(np.max(c.shear()["q_p"])) for c in run.cases]
    epsv = [float(c.shear()["epsv"][-1]) for c in run.cases]
    parts = [("peak q/p grows", increasing(peak)), ("eps_v at the end decreases (more dilation)", decreasing(epsv))]
    v, why = verdict(parts)
    return v, (f"{murs(run)}: peak q/p " + " -> ".join(f3(x) for x in peak) + "; eps_v at the end "
               + " -> ".join(f"{100 * x:.2f} %" for x in epsv) + f" (compression positive).{why}"), \
        "largest q/p of the shear strictly increasing in mu_r; final eps_v strictly decreasing"


def item11(run, ref):
    """Decided on the study's form (weights xi_k = zeta_k gamma_k); the exact form (weights
    p_k / p, the networks' shares of the stress; docs/fabric.md) is stated beside it."""
    rows = []
    ok = ok_exact = True
    for c in run.cases:
        m, mx = sff_deviation(c, "ns_s_sf_wf")
        e, ex = sff_deviation(c, "ns_s_sf_wf", "exact")
        g, _ = sff_deviation(c, "all")
        ok &= m < SFF_CLOSE
        ok_exact &= e < SFF_CLOSE
        rows.append(f"{c.text}: {100 * m:.1f} % (largest {100 * mx:.0f} %) with xi, {100 * e:.1f} % (largest "
                    f"{100 * ex:.0f} %) with the exact shares p_k / p; global network {100 * g:.1f} %")
    exact = "nan" if not all(np.isfinite(sff_deviation(c, "ns_s_sf_wf", "exact")[0]) for c in run.cases) \
        else (HOLDS if ok_exact else FAILS)
    return (HOLDS if ok else FAILS), ("mean deviation of (q/p)* of {ns-sf, ns-wf, s-sf, s-wf} from q/p: "
                                      + "; ".join(rows) + f". With the exact shares as weights the claim {exact}."), \
        (f"mean over the shear rows of |(q/p)* - q/p| / (q/p) below {SFF_CLOSE:.0%} for every mu_r, in the spec's "
         "scalar form with the study's weights xi_k = zeta_k gamma_k (the verdict); the exact form, the same sum "
         "weighted by each network's share of p, p_k / p, stated beside it")


def item12(run, ref):
    e0 = sorted({row.get("void_ratio_consolidated", "") for row in run.summary} - {""})
    mus = run.consolidation_mu_s
    return UNDECIDED, (f"this run consolidates once, with mu_s = {mus:g}: e = {', '.join(e0)}; the trend needs "
                       "runs consolidated with several mu_s"), \
        "needs several consolidation mu_s ([triaxial] consolidation_friction)"


def sff_deviation(case, partition, form="star"):
    """Mean and largest |(q/p)* - q/p| / (q/p) over the shear rows of one partition
    (``form`` = ``star``: the spec's scalar form; ``tensor``: the tensor form of docs/fabric.md;
    ``exact`` and ``exact_tensor``: the same with the networks' exact shares of p as weights;
    ``recombined``: the networks' measured q_k / p_k recombined with those shares)."""
    q = case.sff
    col = f"q_p_{form}_{partition}"
    if col not in q.dtype.names:
        return float("nan"), float("nan")
    pred = q[col]
    ok = np.isfinite(pred) & (q["q_p"] > 0)
    d = np.abs(pred[ok] - q["q_p"][ok]) / q["q_p"][ok]
    return (float(d.mean()), float(d.max())) if d.size else (float("nan"), float("nan"))


ITEMS = [item1, item2, item3, item4, item5, item6, item7, item8, item9, item10, item11, item12]


def decide(run):
    ref = run.reference()
    out = []
    for k, (f, statement) in enumerate(zip(ITEMS, STATEMENTS), start=1):
        v, numbers, criterion = f(run, ref)
        out.append(Finding(k, statement, v, numbers, criterion))
    return out
