"""OUT/report.html: one self-contained page about a triaxial run against the reference study.

``write(run, out, figures)`` writes, for one run, the scene (key parameters and the full scene text), the
run's summary (OUT/summary.csv, version, ranks, snapshots), the table of the study's twelve
findings as decided by apps/paper_findings.py, the stress-force-fabric residuals per partition
and case, and the figures of apps/plot_paper.py embedded as base64 PNG: the page loads nothing
else (no script, no style sheet, no font, no network); its verdicts are marked as those of one
realisation. ``write_ensemble(ens, out, figures)`` writes the page of an ensemble of realisations
(apps/paper_ensemble.py): the ensemble (realisations and seeds, spheres, ranks, groups, protocol),
the criteria of apps/ensemble_findings.py, the twelve findings as OUT/findings.csv has them, the
summary of every realisation, the SFF residuals as the ensemble mean and its 95 % band, and the
ensemble's figures.
"""
import csv
import base64
import html
import os

import numpy as np

import paper_data as pd
import paper_findings as pf
import ensemble_findings as ef

CSS = """
body { font-family: sans-serif; margin: 1.5em auto; max-width: 1200px; color: #222; line-height: 1.4; }
h1 { font-size: 1.6em; } h2 { border-bottom: 1px solid #ccc; padding-bottom: 0.2em; margin-top: 1.6em; }
table { border-collapse: collapse; margin: 0.6em 0; font-size: 0.92em; }
th, td { border: 1px solid #bbb; padding: 0.3em 0.5em; vertical-align: top; text-align: left; }
th { background: #eef1f5; } td.num { text-align: right; font-variant-numeric: tabular-nums; }
td.holds { background: #d9f2d9; font-weight: bold; } td.fails { background: #f8d7d7; font-weight: bold; }
td.undecided { background: #eeeeee; font-weight: bold; }
figure { margin: 1.2em 0; } figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: 0.9em; color: #444; } pre { background: #f6f6f6; padding: 0.6em; overflow-x: auto; }
.small { font-size: 0.88em; color: #555; } .wide { overflow-x: auto; }
"""

CAPTIONS = {
    "fig02": "Void ratio and coordination number after consolidation against the consolidation mu_s "
             "(study's Fig. 2(b)).",
    "ensem": "The trends the findings 7-10 are decided on: each realisation's points, their mean and its band.",
    "fig03": "Force chains of the global, non-sliding, sliding and strong networks at the end of shear.",
    "fig04": "Fabric of the non-sliding and sliding networks (study's Fig. 4).",
    "fig05": "Fabric of ns-nr, ns-r, s-nr, s-r (study's Fig. 5).",
    "fig06": "Fabric of the strong and weak networks (study's Fig. 6).",
    "fig07": "Fabric of ns-sf, ns-wf, s-sf, s-wf (study's Fig. 7).",
    "fig08": "Anisotropy a_c and a_n of the sub-networks (study's Fig. 8).",
    "fig09": "Influence of mu_r on the anisotropy of the global, ns, sf, ns-sf networks (study's Fig. 9).",
    "fig10": "Stress ratio and volumetric strain for every mu_r (study's Fig. 10).",
    "fig11": "Weights xi_k of ns, sf, ns-sf (study's Fig. 11).",
    "fig12": "The SFF prediction against the measured q/p (study's Fig. 12).",
}


def esc(x):
    return html.escape(str(x))


def table(header, rows, cls=None):
    h = "".join(f"<th>{esc(c)}</th>" for c in header)
    body = []
    for r in rows:
        cells = []
        for k, v in enumerate(r):
            c = cls(k, v) if cls else ""
            cells.append(f"<td{c}>{esc(v)}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    return (f"<div class='wide'><table><thead><tr>{h}</tr></thead><tbody>{''.join(body)}</tbody></table>"
            "</div>")


def scene_rows(run):
    """The scene's key parameters: (quantity, value, unit)."""
    s = run.scene
    p, c, t = s.get("particles", {}), s.get("contact", {}), s.get("triaxial", {})
    rows = [
        ("particles", p.get("count", "from a data file"), "spheres"),
        ("diameters", f"{p.get('d_min', '?')} - {p.get('d_max', '?')}", "m"),
        ("fractal dimension D", p.get("fractal_dimension", "?"), ""),
        ("contact model", c.get("model", "linear"), ""),
        ("rolling resistance model", c.get("rolling_model", "elastic_plastic"), ""),
        ("Young's modulus E", c.get("youngs_modulus", "?"), "Pa"),
        ("mu_s (shear)", run.mu_s, ""),
        ("mu_s (consolidation)", run.consolidation_mu_s, ""),
        ("mu_r of the cases", ", ".join(f"{x.mu_r:g}" for x in run.cases), ""),
        ("confining pressure", t.get("confining_pressure", "?"), "Pa"),
        ("axial strain", t.get("axial_strain", "?"), ""),
        ("axial strain rate", t.get("axial_strain_rate", "?"), "1/s"),
    ]
    return [(q, f"{v:g}" if isinstance(v, float) else v, u) for q, v, u in rows]


def scene_section(run):
    return ("<h2 id='scene'>Scene</h2>"
            f"<p>Scene file: <code>{esc(run.info.scene_path)}</code>.</p>"
            + table(["quantity", "value", "unit"], scene_rows(run))
            + f"<details><summary>The scene file as run</summary><pre>{esc(run.info.scene_text)}</pre></details>")


def summary_section(run):
    i = run.info
    snaps = run.h5.snapshots()
    parts = snaps[-1].particles if snaps else 0
    head = (f"<p>Fabrica {esc(i.version)} (git {esc(i.git_describe)}), written by {i.mpi_ranks} MPI rank(s); "
            f"{parts} particles; {len(snaps)} snapshots in <code>run.h5</code>. Figures 3-8 and the findings "
            f"on a single case use {esc(run.reference().text)} (nearest the study's mu_r = 0.05 among mu_r &gt; 0); "
            f"the residual state is eps_1 &ge; {pd.RESIDUAL_FROM:g} &times; the final eps_1.</p>")
    cols = ["case", "rolling_friction", "void_ratio_consolidated", "peak_q_p", "eps1_at_peak", "eps_v_end",
            "q_p_end", "max_lateral_error", "max_energy_error", "max_inertial_number", "wall_seconds"]
    rows = [[r.get(k, "") for k in cols] for r in run.summary]
    cols = [c.replace("_", " ") for c in cols]
    return ("<h2 id='summary'>Run summary</h2>" + head
            + table(cols, rows, lambda k, v: " class='num'" if k > 0 else "")
            + "<p class='small'>From OUT/summary.csv (docs/triaxial.md): eps_v compression positive; "
              "errors relative (lateral stress, energy balance).</p>")


def findings_section(findings):
    css = {pf.HOLDS: " class='holds'", pf.FAILS: " class='fails'", pf.UNDECIDED: " class='undecided'"}
    rows = []
    for f in findings:
        rows.append(f"<tr><td class='num'>{f.number}</td><td>{esc(f.statement)}</td>"
                    f"<td{css[f.verdict]}>{esc(f.verdict)}</td><td>{esc(f.numbers)}</td>"
                    f"<td class='small'>{esc(f.criterion)}</td></tr>")
    n = {v: sum(f.verdict == v for f in findings) for v in (pf.HOLDS, pf.FAILS, pf.UNDECIDED)}
    return ("<h2 id='findings-head'>The study's findings (spec section 7)</h2>"
            f"<p>{n[pf.HOLDS]} hold, {n[pf.FAILS]} do not hold, {n[pf.UNDECIDED]} cannot be decided on this run. "
            "<b>One realisation</b>: the verdicts are those of this one specimen (an ensemble, [triaxial] "
            "realisations, decides them by statistics over its realisations: docs/triaxial.md). The thresholds are "
            "in the last column and in docs/fabric.md.</p>"
            "<table id='findings'><thead><tr><th>#</th><th>the study reports</th><th>verdict</th>"
            "<th>numbers it was decided on</th><th>criterion</th></tr></thead><tbody>"
            + "".join(rows) + "</tbody></table>")


def sff_section(run):
    header = ["partition"]
    for c in run.cases:
        header += [f"{c.text}: mean", "max", "tensor form: mean", "exact shares: mean", "max",
                   "exact shares, tensor: mean"]
    rows = []
    for p in pd.PARTITIONS:
        r = [pd.PARTITION_LABELS[p]]
        for c in run.cases:
            m, mx = pf.sff_deviation(c, p)
            t, _ = pf.sff_deviation(c, p, "tensor")
            e, ex = pf.sff_deviation(c, p, "exact")
            et, _ = pf.sff_deviation(c, p, "exact_tensor")
            pc = lambda v, d=2: f"{100 * v:.{d}f} %" if np.isfinite(v) else "-"  # noqa: E731
            r += [pc(m), pc(mx, 1), pc(t), pc(e), pc(ex, 1), pc(et)]
        rows.append(r)
    return ("<h2 id='sff'>Stress-force-fabric residuals per partition</h2>"
            "<p>|(q/p)* - q/p| / (q/p) over the rows of the shear stage: (q/p)* = 2/5 &Sigma; xi_k (a_c + a_b + "
            "a_n + 3/2 a_t) of the partition (the spec's scalar form, the study's weights xi_k = zeta_k gamma_k), "
            "and the tensor form of docs/fabric.md; then the exact form, the same sums weighted by each network's "
            "share of the mean stress, p_k / p (from the Love-Weber decomposition sigma = &Sigma; sigma^k; "
            "docs/fabric.md, \"Each network's share of the stress\").</p>"
            + table(header, rows, lambda k, v: " class='num'" if k > 0 else ""))


def figures_section(figures):
    out = ["<h2 id='figures'>Figures</h2>"]
    for path in figures:
        name = os.path.basename(path)
        with open(path, "rb") as fh:
            data = base64.b64encode(fh.read()).decode("ascii")
        cap = CAPTIONS.get(name[:5], "")
        out.append(f"<figure><img alt='{esc(name)}' src='data:image/png;base64,{data}'>"
                   f"<figcaption><code>figures/{esc(name)}</code>: {esc(cap)}</figcaption></figure>")
    return "".join(out)


def write(run, out, figures):
    findings = pf.decide(run)
    body = (scene_section(run) + summary_section(run) + findings_section(findings) + sff_section(run)
            + figures_section(figures))
    return save_page(out, page("Fabrica: a periodic triaxial run against the reference study", body))


def page(title, body):
    """The page, written atomically as OUT/report.html by the caller."""
    return ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            f"<title>{esc(title)}</title><style>{CSS}</style></head><body>"
            f"<h1>{esc(title)}</h1>"
            "<p>Wang, Shen, Liu, Chen, <i>Shear-induced anisotropy analysis of contact networks incorporating "
            "particle rolling resistance</i>, Chinese Journal of Theoretical and Applied Mechanics 53(6), 2021, "
            "as restated in shared/spec/reference-problem.md.</p>" + body + "</body></html>\n")


def save_page(out, text):
    path = os.path.join(out, "report.html")
    with open(path + ".tmp", "w", encoding="utf-8") as fh:
        fh.write(text)
    os.replace(path + ".tmp", path)
    return path


def read_csv(path):
    if not os.path.exists(path):
        return []
    with open(path) as fh:
        return list(csv.DictReader(fh))


def ensemble_section(ens):
    """The ensemble: realisations and seeds, spheres, ranks and groups, and the protocol."""
    run = ens.first
    spheres = [r.h5.snapshots()[-1].particles if r.h5.snapshots() else 0 for r in ens.runs]
    ranks = [r.info.mpi_ranks for r in ens.runs]
    t = run.scene.get("triaxial", {})
    cf = t.get("consolidation_friction_cases")
    groups = run.scene.get("parallel", {}).get("groups", 1)
    one = lambda v: f"{v[0]}" if len(set(v)) == 1 else ", ".join(map(str, v))  # noqa: E731
    rows = [("realisations", len(ens.runs), ""),
            ("seeds", ", ".join(ens.seeds), "OUT/seed_<s>/"),
            ("spheres per realisation", one(spheres), "in the last snapshot of each run.h5"),
            ("MPI ranks per realisation", one(ranks), "as each run.h5 records"),
            ("[parallel] groups", groups, "realisations run side by side, one group of ranks each"),
            ("consolidation frictions of finding 12", ", ".join(f"{x:g}" for x in cf) if cf else "none",
             "consolidation_friction_cases: OUT/consolidations.csv")] + scene_rows(run)
    body = "".join(f"<tr><td>{esc(q)}</td><td class='num'>{esc(v)}</td><td>{esc(u)}</td></tr>" for q, v, u in rows)
    return ("<h2 id='ensemble-head'>The ensemble</h2>"
            f"<p>{len(ens.runs)} realisations of the same scene on specimens generated from seeds "
            f"{esc(', '.join(ens.seeds))} (docs/triaxial.md \"Realisations\"), each consolidated at mu_s = "
            f"{run.consolidation_mu_s:g} and sheared at mu_s = {run.mu_s:g} for every mu_r of the sweep. Scene file: "
            f"<code>{esc(run.info.scene_path)}</code>; Fabrica {esc(run.info.version)} (git "
            f"{esc(run.info.git_describe)}).</p>"
            "<div class='wide'><table id='ensemble'><thead><tr><th>quantity</th><th>value</th><th>note or unit</th>"
            f"</tr></thead><tbody>{body}</tbody></table></div>"
            f"<details><summary>The scene file as run</summary><pre>{esc(run.info.scene_text)}</pre></details>")


def criteria_section():
    items = "".join(f"<li>{esc(c)}</li>" for c in ef.CRITERIA)
    return ("<h2 id='criteria-head'>How the findings are decided over the realisations</h2>"
            "<p>By apps/ensemble_findings.py (docs/triaxial.md \"Findings over realisations\"); a verdict is "
            f"<b>{esc(ef.HOLDS)}</b>, <b>{esc(ef.FAILS)}</b> or <b>{esc(ef.UNDECIDED)}</b>:</p>"
            f"<ol id='criteria'>{items}</ol>"
            "<p>The figures draw at every point the mean over the realisations with a finite value there and its "
            "95 % band, mean &plusmn; t(0.975, n - 1) s / &radic;n (s the sample standard deviation); a curve "
            "against eps_1 is first interpolated linearly onto the first realisation's eps_1 within every "
            "realisation's range. The numbers of every band are in <code>figures/ensemble_bands.csv</code> "
            "(apps/paper_ensemble.py).</p>")


def ensemble_findings_section(rows, n):
    css = {ef.HOLDS: " class='holds'", ef.FAILS: " class='fails'", ef.UNDECIDED: " class='undecided'"}
    body = []
    for r in rows:
        k = int(r["finding"])
        body.append(f"<tr><td class='num'>{k}</td><td>{esc(pf.STATEMENTS[k - 1])}</td>"
                    f"<td{css.get(r['verdict'], '')}>{esc(r['verdict'])}</td><td>{esc(r['numbers'])}</td>"
                    f"<td class='small'>{esc(r['criterion'])}</td></tr>")
    count = {v: sum(r["verdict"] == v for r in rows) for v in (ef.HOLDS, ef.FAILS, ef.UNDECIDED)}
    return ("<h2 id='findings-head'>The study's findings (spec section 7) over the ensemble</h2>"
            f"<p>Over {n} realisations (OUT/findings.csv): {count[ef.HOLDS]} hold, {count[ef.FAILS]} do not hold, "
            f"{count[ef.UNDECIDED]} are undecided at this ensemble size.</p>"
            "<table id='findings'><thead><tr><th>#</th><th>the study reports</th><th>verdict</th>"
            "<th>numbers it was decided on</th><th>criterion</th></tr></thead><tbody>"
            + "".join(body) + "</tbody></table>")


def ensemble_summary_section(out):
    rows = read_csv(os.path.join(out, "summary.csv"))
    if not rows:
        return ""
    cols = list(rows[0])
    return ("<h2 id='summary'>Summary of every realisation</h2>"
            + table([c.replace("_", " ") for c in cols], [[r[c] for c in cols] for r in rows],
                    lambda k, v: " class='num'" if k != 1 else "")
            + "<p class='small'>OUT/summary.csv (docs/triaxial.md): one row per realisation and case, its seed "
              "first.</p>")


def ensemble_sff_section(ens):
    import paper_ensemble
    header = ["partition"]
    for name in ens.names:
        header += [f"{ens.cases(name)[0].text}: study's weights", "exact shares"]
    rows = []
    for p in pd.PARTITIONS:
        r = [pd.PARTITION_LABELS[p]]
        for name in ens.names:
            for form in ("star", "exact"):
                b = paper_ensemble.sff_band(ens, name, p, form)
                m, h = 100 * b.mean[0], 100 * b.half_width[0]
                r.append(f"{m:.2f} &plusmn; {h:.2f} %" if np.isfinite(m) else "-")
        rows.append(r)
    body = "".join("<tr>" + "".join(f"<td{' class=num' if k else ''}>{v if k else esc(v)}</td>"
                                    for k, v in enumerate(r)) + "</tr>" for r in rows)
    head = "".join(f"<th>{esc(h)}</th>" for h in header)
    return ("<h2 id='sff'>Stress-force-fabric residuals per partition</h2>"
            "<p>The mean |(q/p)* - q/p| / (q/p) over the shear stage of each realisation (as on one run), "
            "then their mean over the realisations and its 95 % band.</p>"
            f"<div class='wide'><table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table></div>")


def write_ensemble(ens, out, figures):
    rows = read_csv(os.path.join(out, "findings.csv"))
    body = (ensemble_section(ens) + criteria_section() + ensemble_findings_section(rows, len(ens.runs))
            + ensemble_summary_section(out) + ensemble_sff_section(ens) + figures_section(figures))
    return save_page(out, page(f"Fabrica: {len(ens.runs)} realisations of a periodic triaxial test against "
                               "the reference study", body))
