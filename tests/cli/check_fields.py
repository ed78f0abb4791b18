"""Checks the coarse-grained fields written by `fabrica fields` (docs/fields.md) against the
snapshots they were computed from, through apps/fabrica_h5.py:

    check_fields.py integrals RUN.h5 FIELDS.h5   at every instant of FIELDS.h5, the volume
        integral (sum over the nodes x the cell volume of a node) of contact_stress equals the
        Love-Weber sum f (x) b of the snapshot's particle contacts (relative to its norm, 1e-12),
        of stress that sum plus the integral of kinetic_stress (1e-12; a sheared cell's node
        volume |det H| / N, H its cell_matrix),
        of solid_fraction the solid volume (1e-12), of contact_density_all the number of
        particle contacts (1e-12); every field has the grid's shape; the strain increment is the
        symmetric part of the displacement gradient.
    check_fields.py same A.h5 B.h5   every dataset of /fields and every attribute of its groups
        identical in the two files, bit for bit (NaN included): the rank-count independence.
        Either may be a run's run.h5 (its /fields group: the fields of [fields] in the run).
    check_fields.py inrun RUN.h5 FIELDS.h5 CASE STEPS   the fields computed during the run
        ([fields], /fields/CASE/<step> of RUN.h5) are at the steps STEPS (comma-separated) and
        equal, bit for bit, those `fabrica fields RUN.h5 --all` wrote to FIELDS.h5 from the
        run's snapshots at the same steps: the same datasets and attributes in both, every one
        equal; every instant but the first holds the displacement fields from the one before
        (displacement, displacement_gradient, strain_increment; displacement_from_step), the
        first none.
    check_fields.py localisation RUN_DIR CASE [CSV]   the run's series column localisation (in
        RUN_DIR/run.h5 /series/CASE and in the CSV, default RUN_DIR/series.csv) equals, at each
        field instant with a strain increment, apps/localisation.py's index of that instant's
        strain_increment in run.h5 (1e-12; the CSV to its 10 significant digits), and is NaN
        (`nan`) at every other row.
    check_fields.py sweep RUN.h5 SOURCE OTHER   a triaxial sweep's field instants: the first of
        each case has no displacement fields, every later one those from the case's instant
        before; the instants of the re-equilibration SOURCE ran for both are OTHER's too (the
        same HDF5 objects: hard links), and OTHER's first own instant (its shear's) has its
        displacement from the last of them.
    check_fields.py cellshear FIELDS.h5 CASE   a case whose cell shears past a flip of its edges:
        at least one flip between two instants (H1 = F H0 M, M = round(H0^-1 H1) not I), and at
        every instant with displacement fields the mean over the nodes of displacement_gradient
        equals the cell's own F - I (the flip undone) within 5 % of |F - I|.
Exits 0 if all hold, 1 with the reason, 77 if h5py or numpy is missing.
"""
import os
import sys

try:
    import h5py
    import numpy as np
except ImportError as e:
    print(f"check_fields.py: skipped: {e} (install python3-h5py and python3-numpy)")
    sys.exit(77)

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "apps"))
import fabrica_h5  # noqa: E402

TOL = 1e-12


def fail(msg):
    print(f"check_fields.py: FAIL: {msg}")
    sys.exit(1)


def integrals(run_path, fields_path):
    run, fl = fabrica_h5.RunFile(run_path), fabrica_h5.RunFile(fields_path)
    instants = fl.field_instants()
    if not instants:
        fail(f"{fields_path}: no fields")
    worst = [0.0, 0.0, 0.0]
    for inst in instants:
        f = fl.fields(inst.case, inst.step)
        nx, ny, nz = inst.cells
        dv = abs(np.linalg.det(inst.cell_matrix)) / (nx * ny * nz) if inst.sheared else \
            np.prod(inst.cell_lengths) / (nx * ny * nz)
        for name, v in f.items():
            if v.shape[:3] != (nx, ny, nz):
                fail(f"{inst.case} step {inst.step}: {name} has shape {v.shape}, grid {nx} {ny} {nz}")
        c = run.contacts(inst.case, inst.step)
        pp = c.id2 >= 0
        force = c.fn[pp, None] * c.normal[pp] + c.ft[pp]
        lw = np.einsum("ci,cj->ij", force, c.branch[pp])
        integral = f["contact_stress"].sum(axis=(0, 1, 2)) * dv
        if "stress" in f and "kinetic_stress" in f:  # the stress: the contacts' and the kinetic part
            total = (f["stress"].sum(axis=(0, 1, 2)) - f["kinetic_stress"].sum(axis=(0, 1, 2))) * dv
            if np.linalg.norm(lw) > 0 and not np.linalg.norm(total - lw) / np.linalg.norm(lw) <= TOL:
                fail(f"{inst.case} step {inst.step}: stress - kinetic stress integral vs Love-Weber: "
                     f"{np.linalg.norm(total - lw) / np.linalg.norm(lw):.3e}")
        p = run.particles(inst.case, inst.step)
        solid = (4.0 / 3.0 * np.pi * p.radius ** 3).sum()
        errs = [np.linalg.norm(integral - lw) / np.linalg.norm(lw) if np.linalg.norm(lw) > 0 else 0.0,
                abs(f["solid_fraction"].sum() * dv - solid) / solid,
                abs(f["contact_density_all"].sum() * dv - pp.sum()) / max(pp.sum(), 1)]
        for k, (e, what) in enumerate(zip(errs, ("contact stress vs Love-Weber", "solid fraction vs solid volume",
                                                 "contact density vs contact count"))):
            worst[k] = max(worst[k], e)
            if not e <= TOL:
                fail(f"{inst.case} step {inst.step}: {what}: relative error {e:.3e} > {TOL}")
        if "displacement_gradient" in f:
            g, e = f["displacement_gradient"], f["strain_increment"]
            sym = 0.5 * (g + np.swapaxes(g, 3, 4))
            ok = np.isfinite(g)
            if not np.array_equal(np.isfinite(e), ok) or np.abs(e[ok] - sym[ok]).max(initial=0) > 1e-15:
                fail(f"{inst.case} step {inst.step}: strain_increment is not the symmetric part of the gradient")
    sheared = sum(i.sheared for i in instants)
    print(f"check_fields.py: {len(instants)} instants ({sheared} on a sheared cell); largest relative errors: "
          "contact stress integral "
          f"{worst[0]:.1e}, solid volume {worst[1]:.1e}, contact count {worst[2]:.1e} (tolerance {TOL})")


def same(a_path, b_path):
    with h5py.File(a_path, "r") as a, h5py.File(b_path, "r") as b:
        names = []
        a["fields"].visit(names.append)
        other = []
        b["fields"].visit(other.append)
        if sorted(names) != sorted(other):
            fail(f"{a_path} and {b_path} hold different objects")
        n = 0
        for name in names:
            x, y = a["fields"][name], b["fields"][name]
            for k in x.attrs:
                if not np.array_equal(np.asarray(x.attrs[k]), np.asarray(y.attrs[k])):
                    fail(f"/fields/{name}: attribute {k} differs")
            if isinstance(x, h5py.Dataset):
                u, v = x[()], y[()]
                if u.shape != v.shape or u.tobytes() != v.tobytes():
                    fail(f"/fields/{name}: values differ")
                n += u.size
    print(f"check_fields.py: {len(names)} objects, {n} values identical, bit for bit")


def inrun(run_path, fields_path, case, steps):
    want = sorted(int(x) for x in steps.split(","))
    with h5py.File(run_path, "r") as a, h5py.File(fields_path, "r") as b:
        if "fields" not in a or case not in a["fields"]:
            fail(f"{run_path}: no /fields/{case}")
        ga = a["fields"][case]
        got = sorted(int(ga[s].attrs["step"]) for s in ga)
        if got != want:
            fail(f"{run_path}: field instants at steps {got}, expected {want}")
        n = 0
        displaced = 0
        for s in ga:
            x = ga[s]
            if s not in b["fields"][case]:
                fail(f"{fields_path}: no /fields/{case}/{s} (a snapshot at step {int(x.attrs['step'])}?)")
            y = b["fields"][case][s]
            if sorted(x) != sorted(y) or sorted(x.attrs) != sorted(y.attrs):
                fail(f"/fields/{case}/{s}: datasets {sorted(set(x) ^ set(y))} and attributes "
                     f"{sorted(set(x.attrs) ^ set(y.attrs))} in one file only")
            step = int(x.attrs["step"])
            disp = {"displacement", "displacement_gradient", "strain_increment"}
            if step == want[0]:
                if disp & set(x) or "displacement_from_step" in x.attrs:
                    fail(f"/fields/{case}/{s}: displacement fields at the case's first instant")
            else:
                if not disp <= set(x):
                    fail(f"/fields/{case}/{s}: no displacement fields ({sorted(disp - set(x))} missing)")
                prev = want[want.index(step) - 1]
                if int(x.attrs["displacement_from_step"]) != prev:
                    fail(f"/fields/{case}/{s}: displacement from step {x.attrs['displacement_from_step']}, not {prev}")
                displaced += 1
            for k in x.attrs:
                if k not in y.attrs or not np.array_equal(np.asarray(x.attrs[k]), np.asarray(y.attrs[k])):
                    fail(f"/fields/{case}/{s}: attribute {k}: {x.attrs[k]} in the run, "
                         f"{y.attrs.get(k)} offline")
            for d in x:
                if d not in y:
                    fail(f"/fields/{case}/{s}/{d}: not computed offline")
                u, v = x[d][()], y[d][()]
                if u.shape != v.shape or u.tobytes() != v.tobytes():
                    bad = int(np.sum(~((u == v) | (np.isnan(u) & np.isnan(v))))) if u.shape == v.shape else -1
                    fail(f"/fields/{case}/{s}/{d}: the run's values differ from the offline ones ({bad} values)")
                if x[d].attrs["unit"] != y[d].attrs["unit"]:
                    fail(f"/fields/{case}/{s}/{d}: unit {x[d].attrs['unit']} vs {y[d].attrs['unit']}")
                n += u.size
    # The reader of the apps (apps/fabrica_h5.py) finds them in run.h5: the instants and each
    # field, transposed to [i, j, k] from the file's (nz, ny, nx).
    rf = fabrica_h5.RunFile(run_path)
    inst = rf.field_instants(case)
    if [i.step for i in inst] != want:
        fail(f"fabrica_h5.py: field instants {[i.step for i in inst]} of {run_path}, expected {want}")
    f = rf.fields(case, want[-1], ["solid_fraction"])["solid_fraction"]
    with h5py.File(run_path, "r") as a:
        raw = a["fields"][case][f"{want[-1]:012d}"]["solid_fraction"][()]
    if f.shape != raw.shape[::-1] or not np.array_equal(f, np.swapaxes(raw, 0, 2)):
        fail(f"fabrica_h5.py: solid_fraction of {run_path} at step {want[-1]} read as {f.shape}, not the file's")
    print(f"check_fields.py: {len(got)} field instants of the run at steps {got}: {n} values identical "
          f"to `fabrica fields`, bit for bit, {displaced} of the instants with displacement fields; "
          f"fabrica_h5.py reads them from run.h5")


def sweep(run_path, source, other):
    with h5py.File(run_path, "r") as h:
        f = h["fields"]
        for case in (source, other):
            steps = sorted(int(f[case][s].attrs["step"]) for s in f[case])
            for k, step in enumerate(steps):
                x = f[case][f"{step:012d}"]
                got = int(x.attrs["displacement_from_step"]) if "displacement_from_step" in x.attrs else None
                want = steps[k - 1] if k > 0 else None
                if got != want or (want is not None) != ("strain_increment" in x):
                    fail(f"/fields/{case}/{step:012d}: displacement from step {got}, expected {want}")
        linked = [s for s in f[other] if s in f[source] and f[other][s] == f[source][s]]
        own = [s for s in f[other] if s not in linked]
        if not linked or not own or max(linked) > min(own):
            fail(f"{other}: linked instants {linked} are not the first ones (own {own})")
        first = f[other][min(own)]
        if int(first.attrs["displacement_from_step"]) != int(f[source][max(linked)].attrs["step"]):
            fail(f"{other}: its first own instant's displacement is not from the re-equilibration's last")
    print(f"check_fields.py: {len(linked)} instants of {source}'s re-equilibration linked into {other}, whose "
          f"first shear instant starts from the last of them; every later instant of each case from the one before")


def localisation(run_dir, case, csv_path=None):
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "apps"))
    import localisation as lo  # noqa: E402
    run_path = os.path.join(run_dir, "run.h5")
    rf = fabrica_h5.RunFile(run_path)
    want = {}
    for inst in rf.field_instants(case):
        f = rf.fields(inst.case, inst.step)
        if "strain_increment" in f:
            want[inst.step] = lo.localisation_index(lo.shear_intensity(f["strain_increment"]))
    if not want:
        fail(f"{run_path}: no field instant of case {case} with a strain increment")
    with h5py.File(run_path, "r") as h:
        g = h["series"][case]
        if "localisation" not in g:
            fail(f"{run_path}: no series column localisation in /series/{case}")
        steps, col = g["step"][()], g["localisation"][()]
    csv_path = csv_path or os.path.join(run_dir, "series.csv")
    with open(csv_path) as f:
        rows = [line.rstrip("\n").split(",") for line in f]
    head = rows[0]
    if head[-1] != "localisation":
        fail(f"{csv_path}: last column {head[-1]}, not localisation")
    csv = {int(r[head.index("step")]): r[-1] for r in rows[1:]}
    worst = 0.0
    for step, v in zip(steps, col):
        step = int(step)
        if step in want:
            err = abs(v - want[step])
            worst = max(worst, err)
            if not err <= TOL:
                fail(f"step {step}: localisation {v!r} in the series, {want[step]!r} from localisation.py")
            if abs(float(csv[step]) - want[step]) > 1e-9 * want[step]:
                fail(f"step {step}: {csv_path} localisation {csv[step]}, localisation.py {want[step]!r}")
        elif not (np.isnan(v) and csv[step] == "nan"):
            fail(f"step {step}: localisation {v!r} ({csv[step]} in the CSV) at a row without a strain increment")
    missing = sorted(set(want) - {int(s) for s in steps})
    if missing:
        fail(f"no series row at the field instants {missing}")
    print(f"check_fields.py: {case}: the series' localisation equals localisation.py's index at the {len(want)} "
          f"instants with a strain increment (largest difference {worst:.1e}, tolerance {TOL}; "
          f"values {min(want.values()):.4f}-{max(want.values()):.4f}), NaN at the {len(steps) - len(want)} other rows")


def cellshear(path, case):
    fl = fabrica_h5.RunFile(path)
    inst = {i.step: i for i in fl.field_instants(case)}
    flips, worst, n = 0, 0.0, 0
    for step, i in sorted(inst.items()):
        if i.displacement_from_step < 0:
            continue
        h0, h1 = inst[i.displacement_from_step].cell_matrix, i.cell_matrix
        m = np.round(np.linalg.solve(h0, h1))
        flips += not np.array_equal(m, np.eye(3))
        f = h1 @ np.linalg.inv(m) @ np.linalg.inv(h0)
        g = fl.fields(case, step, ["displacement_gradient"])["displacement_gradient"]
        mean = np.nanmean(g.reshape(-1, 3, 3), axis=0)
        e = np.linalg.norm(mean - (f - np.eye(3))) / np.linalg.norm(f - np.eye(3))
        worst, n = max(worst, e), n + 1
        if not e <= 0.05:
            fail(f"{case} step {step}: mean displacement gradient {mean.tolist()} against the cell's F - I "
                 f"{(f - np.eye(3)).tolist()}: {e:.3f} of |F - I|")
    if flips == 0:
        fail(f"{path}: no flip of the cell's edges between two instants of {case}")
    print(f"check_fields.py: {case}: {n} instants with displacement fields, {flips} across a flip of the cell's "
          f"edges; the mean displacement gradient is the cell's F - I within {worst:.2e} of |F - I|")


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "cellshear":
        cellshear(*sys.argv[2:])
        sys.exit(0)
    if len(sys.argv) == 6 and sys.argv[1] == "inrun":
        inrun(*sys.argv[2:])
        sys.exit(0)
    if len(sys.argv) in (4, 5) and sys.argv[1] == "localisation":
        localisation(*sys.argv[2:])
        sys.exit(0)
    if len(sys.argv) == 5 and sys.argv[1] == "sweep":
        sweep(*sys.argv[2:])
        sys.exit(0)
    if len(sys.argv) != 4 or sys.argv[1] not in ("integrals", "same"):
        print(__doc__)
        sys.exit(2)
    (integrals if sys.argv[1] == "integrals" else same)(sys.argv[2], sys.argv[3])
