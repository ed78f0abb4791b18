"""Checks the coarse-grained fields written by `fabrica fields` (docs/fields.md) against the
snapshots they were computed from, through apps/fabrica_h5.py:

    check_fields.py integrals RUN.h5 FIELDS.h5   at every instant of FIELDS.h5, the volume
        integral (sum over the nodes x the cell volume of a node) of contact_stress equals the
        Love-Weber sum f (x) b of the snapshot's particle contacts (relative to its norm, 1e-12),
        of solid_fraction the solid volume (1e-12), of contact_density_all the number of
        particle contacts (1e-12); every field has the grid's shape; the strain increment is the
        symmetric part of the displacement gradient.
    check_fields.py same A.h5 B.h5   every dataset of /fields and every attribute of its groups
        identical in the two files, bit for bit (NaN included): the rank-count independence.
        Either may be a run's run.h5 (its /fields group: the fields of [fields] in the run).
    check_fields.py inrun RUN.h5 FIELDS.h5 CASE STEPS   the fields computed during the run
        ([fields], /fields/CASE/<step> of RUN.h5) are at the steps STEPS (comma-separated) and
        equal, bit for bit, those `fabrica fields RUN.h5 --all` wrote to FIELDS.h5 from the
        run's snapshots at the same steps: every dataset of the run's instants, and every
        attribute of their groups.
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
        dv = np.prod(inst.cell_lengths) / (nx * ny * nz)
        for name, v in f.items():
            if v.shape[:3] != (nx, ny, nz):
                fail(f"{inst.case} step {inst.step}: {name} has shape {v.shape}, grid {nx} {ny} {nz}")
        c = run.contacts(inst.case, inst.step)
        pp = c.id2 >= 0
        force = c.fn[pp, None] * c.normal[pp] + c.ft[pp]
        lw = np.einsum("ci,cj->ij", force, c.branch[pp])
        integral = f["contact_stress"].sum(axis=(0, 1, 2)) * dv
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
    print(f"check_fields.py: {len(instants)} instants; largest relative errors: contact stress integral "
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
        for s in ga:
            x = ga[s]
            if s not in b["fields"][case]:
                fail(f"{fields_path}: no /fields/{case}/{s} (a snapshot at step {int(x.attrs['step'])}?)")
            y = b["fields"][case][s]
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
          f"to `fabrica fields`, bit for bit; fabrica_h5.py reads them from run.h5")


if __name__ == "__main__":
    if len(sys.argv) == 6 and sys.argv[1] == "inrun":
        inrun(*sys.argv[2:])
        sys.exit(0)
    if len(sys.argv) != 4 or sys.argv[1] not in ("integrals", "same"):
        print(__doc__)
        sys.exit(2)
    (integrals if sys.argv[1] == "integrals" else same)(sys.argv[2], sys.argv[3])
