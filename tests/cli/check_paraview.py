"""Opens a run's XDMF sidecars in ParaView and checks them against run.h5 (read with h5py).

    pvpython check_paraview.py OUT [--png FILE] [--no-render]

For OUT/run.xmf and every OUT/run_<case>.xmf, with ParaView's Xdmf3 reader (Xdmf3ReaderS), from
another working directory (run.h5 is named relative to the xmf file):
  - the time steps are the snapshot times of run.h5: one per snapshot of the file's case (all
    of them for a single-case file; for run.xmf of a triaxial run, whose cases overlap in time,
    the set of distinct times);
  - at every time step of a single-case file: N points and N vertex cells (N = the snapshot's
    particle count), point arrays radius, velocity, spin and id, and coordinates, radius,
    velocity, spin and id equal to run.h5's (same type, float64 or int64, compared with ==);
  - a Glyph filter (Glyph Type Sphere, Scale Array radius, Scale Factor 2, All Points) on the
    last snapshot of one file: every vertex of every sphere lies at distance radius (relative
    1e-5: the glyph points are float32) from its particle's centre, i.e. scale factor 2 gives spheres of the particle's radius
    (the sphere glyph source has radius 0.5);
  - unless --no-render: shows the glyphs coloured by radius and saves a PNG (SaveScreenshot),
    which must not be blank.
Exits 0 if all hold, 1 (with the reason) otherwise, 77 (ctest: skipped) if h5py or numpy is
missing. The Debian paraview package renders through X: run under xvfb-run without a display.
"""
import glob
import os
import sys

try:
    import h5py
    import numpy as np
except ImportError as e:
    print(f"check_paraview.py: skipped: {e} (install python3-h5py and python3-numpy)")
    sys.exit(77)

from paraview import servermanager as sm
from paraview import simple as pv
from paraview.vtk.util.numpy_support import vtk_to_numpy


def fail(msg):
    print(f"check_paraview.py: FAIL: {msg}")
    sys.exit(1)


def blocks(d):
    """The leaf datasets of a reader output (a dataset, or a multiblock of them)."""
    if not d.IsA("vtkCompositeDataSet"):
        return [d]
    out = []
    it = d.NewIterator()
    it.InitTraversal()
    while not it.IsDoneWithTraversal():
        out.append(it.GetCurrentDataObject())
        it.GoToNextItem()
    return out


def point_array(ds, name, where):
    a = ds.GetPointData().GetArray(name)
    if a is None:
        names = [ds.GetPointData().GetArrayName(i) for i in range(ds.GetPointData().GetNumberOfArrays())]
        fail(f"{where}: no point array '{name}' (point arrays: {names})")
    return vtk_to_numpy(a)


def snapshots(f, case):
    """[(step name, time, group)] of a case, in step order."""
    g = f["snapshots"][case]
    return [(s, float(g[s].attrs["time"]), g[s]) for s in sorted(g)]


def check_file(xmf, f, cases):
    name = os.path.basename(xmf)
    reader = pv.Xdmf3ReaderS(FileName=[xmf])
    reader.UpdatePipelineInformation()
    times = [float(t) for t in reader.TimestepValues]
    snaps = [s for c in cases for s in snapshots(f, c)]
    if len(cases) > 1:
        want = sorted({t for _, t, _ in snaps})
        if times != want:
            fail(f"{name}: {len(times)} time steps, run.h5 has {len(want)} distinct snapshot times")
        reader.UpdatePipeline(times[0])
        n = sum(b.GetNumberOfPoints() for b in blocks(sm.Fetch(reader)))
        if n == 0:
            fail(f"{name}: no points at t = {times[0]}")
        print(f"{name}: {len(cases)} cases, {len(snaps)} snapshots, {len(times)} distinct times (= run.h5)")
        pv.Delete(reader)
        return None
    if times != [t for _, t, _ in snaps]:
        fail(f"{name}: time steps {times[:4]}... ({len(times)}) are not the {len(snaps)} snapshot times "
             f"of case {cases[0]} in run.h5 {[t for _, t, _ in snaps][:4]}...")
    for step, t, g in snaps:
        reader.UpdatePipeline(t)
        bl = [b for b in blocks(sm.Fetch(reader)) if b is not None]
        if len(bl) != 1:
            fail(f"{name}: {len(bl)} datasets at t = {t}")
        ds = bl[0]
        where = f"{name} step {step} (t = {t})"
        p = g["particles"]
        n = p["id"].shape[0]
        if ds.GetNumberOfPoints() != n:
            fail(f"{where}: {ds.GetNumberOfPoints()} points, run.h5 has {n} particles")
        if ds.GetNumberOfCells() != n or any(ds.GetCell(i).GetNumberOfPoints() != 1 for i in range(n)):
            fail(f"{where}: {ds.GetNumberOfCells()} cells, expected {n} vertices (one per particle)")
        x = vtk_to_numpy(ds.GetPoints().GetData())
        checks = [("coordinates", x, p["position"][()]), ("radius", point_array(ds, "radius", where), p["radius"][()]),
                  ("velocity", point_array(ds, "velocity", where), p["velocity"][()]),
                  ("spin", point_array(ds, "spin", where), p["spin"][()]), ("id", point_array(ds, "id", where), p["id"][()])]
        for what, got, ref in checks:
            if got.dtype != ref.dtype or got.shape != ref.shape or not np.array_equal(got, ref):
                fail(f"{where}: {what} differs from run.h5 (shape {got.shape} vs {ref.shape}, dtype {got.dtype})")
    print(f"{name}: case {cases[0]}, {len(times)} time steps = snapshots; every step: points, vertices, "
          f"coordinates, radius, velocity, spin, id equal to run.h5")
    return reader, snaps[-1]


def check_glyphs(reader, last, png):
    step, t, g = last
    glyph = pv.Glyph(Input=reader, GlyphType="Sphere")
    glyph.GlyphType.ThetaResolution = 24
    glyph.GlyphType.PhiResolution = 16
    if abs(glyph.GlyphType.Radius - 0.5) > 0:
        fail(f"the sphere glyph's radius is {glyph.GlyphType.Radius}, not 0.5: the scale factor 2 is wrong")
    glyph.ScaleArray = ["POINTS", "radius"]
    glyph.OrientationArray = ["POINTS", "No orientation array"]
    glyph.ScaleFactor = 2.0
    glyph.GlyphMode = "All Points"
    glyph.UpdatePipeline(t)
    out = sm.Fetch(glyph)
    if out.IsA("vtkCompositeDataSet"):
        out = blocks(out)[0]
    ids = vtk_to_numpy(out.GetPointData().GetArray("id"))
    pts = vtk_to_numpy(out.GetPoints().GetData()).astype(np.float64)
    p = g["particles"]
    pid, centre, radius = p["id"][()], p["position"][()], p["radius"][()]
    row = np.searchsorted(pid, ids)
    dist = np.linalg.norm(pts - centre[row], axis=1)
    err = np.abs(dist / radius[row] - 1).max()
    if len(np.unique(ids)) != len(pid):
        fail(f"glyphs for {len(np.unique(ids))} particles, run.h5 has {len(pid)}")
    if err > 1e-5:  # the glyph filter's points are float32
        fail(f"sphere glyphs (scale factor 2, Scale Array radius) are not of the particle radius: "
             f"largest relative error {err:.2e}")
    print(f"glyphs at step {step}: {len(pid)} spheres, {out.GetNumberOfPoints()} vertices, each at distance "
          f"radius from its centre (largest relative error {err:.1e})")
    if png is None:
        print("rendering skipped (--no-render)")
        return
    view = pv.CreateView("RenderView")
    view.ViewSize = [800, 600]
    view.OrientationAxesVisibility = 1
    view.ViewTime = t
    view.Background = [1, 1, 1]
    if hasattr(view, "UseColorPaletteForBackground"):
        view.UseColorPaletteForBackground = 0
    d = pv.Show(glyph, view)
    pv.ColorBy(d, ("POINTS", "radius"))
    d.SetScalarBarVisibility(view, True)
    bar = pv.GetScalarBar(pv.GetColorTransferFunction("radius"), view)
    bar.Title, bar.ComponentTitle = "radius", "(m)"
    bar.TitleColor = bar.LabelColor = [0, 0, 0]
    bar.RangeLabelFormat = "%-#.3f"
    pv.Render(view)
    b = out.GetBounds()
    c = [(b[0] + b[1]) / 2, (b[2] + b[3]) / 2, (b[4] + b[5]) / 2]
    view.CameraFocalPoint = c
    view.CameraPosition = [c[0] + 1.0, c[1] - 1.6, c[2] + 0.9]
    view.CameraViewUp = [0, 0, 1]
    view.ResetCamera()
    view.CameraParallelProjection = 0
    print("camera", list(view.CameraPosition), list(view.CameraFocalPoint))
    pv.Render(view)
    pv.SaveScreenshot(png, view, ImageResolution=[800, 600])
    from paraview.vtk.vtkIOImage import vtkPNGReader
    r = vtkPNGReader()
    r.SetFileName(png)
    r.Update()
    img = vtk_to_numpy(r.GetOutput().GetPointData().GetScalars())[:, :3].astype(int)
    coloured = np.count_nonzero(np.abs(img - img[0]).sum(axis=1) > 30) / len(img)
    if coloured < 0.05:
        fail(f"{png}: blank image ({coloured:.1%} of the pixels differ from the background)")
    print(f"rendered {png}: {os.path.getsize(png)} bytes, {coloured:.0%} of the pixels show spheres")


def main():
    args = sys.argv[1:]
    if not args:
        sys.exit(__doc__)
    out = os.path.abspath(args[0])
    png = os.path.abspath(args[args.index("--png") + 1]) if "--png" in args else os.path.join(out, "paraview_glyphs.png")
    if "--no-render" in args:
        png = None
    print(sm.vtkSMProxyManager.GetParaViewSourceVersion())
    f = h5py.File(os.path.join(out, "run.h5"), "r")
    cases = sorted(f["snapshots"])
    os.chdir("/")  # run.h5 must be found relative to the xmf file, not the working directory
    files = {os.path.join(out, "run.xmf"): cases}
    if len(cases) > 1:
        files.update({os.path.join(out, f"run_{c}.xmf"): [c] for c in cases})
    # the contacts' sidecars run*_contacts.xmf are checked by check_paraview_contacts.py, a sheared
    # cell's run*_cell.xmf by check_paraview_cell.py
    extra = set(glob.glob(os.path.join(out, "run_*.xmf"))) - set(files) - set(glob.glob(os.path.join(out, "run*_contacts.xmf"))) \
        - set(glob.glob(os.path.join(out, "run*_cell.xmf")))
    if extra:
        fail(f"unexpected xmf files {sorted(extra)} (cases in run.h5: {cases})")
    last = None
    for xmf, cs in files.items():
        if not os.path.exists(xmf):
            fail(f"{xmf} missing")
        r = check_file(xmf, f, cs)
        if r is not None:
            last = r
    check_glyphs(*last, png)
    print("check_paraview.py: OK")


if __name__ == "__main__":
    main()
