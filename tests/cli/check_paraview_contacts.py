"""Opens a run's contacts sidecars (OUT/run_contacts.xmf, OUT/run_<case>_contacts.xmf) in
ParaView and checks them against run.h5 (read with h5py); renders the strong force chains.

    pvpython check_paraview_contacts.py OUT [--png FILE] [--no-render]

With ParaView's Xdmf3 reader (Xdmf3ReaderS), from another working directory:
  - every run_<case>_contacts.xmf (and run_contacts.xmf for a single-case run) has one time step
    per snapshot of the case that has contacts, at the snapshot's time;
  - at every time step: M cells, each a line of 2 points (VTK_LINE or a 2-point VTK_POLY_LINE),
    2M points; the points of cell k are contacts/ends[k] (x1, x1 + branch) and the cell arrays
    fn, ft_norm, mr_norm (float64), sliding, rolling, strong (uint8), id1, id2 (int64) equal
    run.h5's (compared with ==);
  - a Threshold on the cell array strong (between 1 and 1) at the last snapshot of one case keeps
    exactly the contacts stored as strong, whose f_n all exceed those of the weak ones;
  - unless --no-render: these strong chains, drawn as tubes coloured by fn, saved as a PNG that
    must not be blank.
Exits 0 if all hold, 1 with the reason otherwise, 77 if h5py or numpy is missing.
"""
import os
import sys

try:
    import h5py
    import numpy as np
except ImportError as e:
    print(f"check_paraview_contacts.py: skipped: {e} (install python3-h5py and python3-numpy)")
    sys.exit(77)

from paraview import servermanager as sm
from paraview import simple as pv
from paraview.vtk.util.numpy_support import vtk_to_numpy

ARRAYS = {"fn": np.float64, "ft_norm": np.float64, "mr_norm": np.float64, "sliding": np.uint8,
          "rolling": np.uint8, "strong": np.uint8, "id1": np.int64, "id2": np.int64}


def fail(msg):
    print(f"check_paraview_contacts.py: FAIL: {msg}")
    sys.exit(1)


def leaf(d):
    """The one dataset of a reader output (a dataset, or a multiblock holding one)."""
    if not d.IsA("vtkCompositeDataSet"):
        return d
    it = d.NewIterator()
    it.InitTraversal()
    out = []
    while not it.IsDoneWithTraversal():
        out.append(it.GetCurrentDataObject())
        it.GoToNextItem()
    if len(out) != 1:
        fail(f"{len(out)} blocks, expected 1")
    return out[0]


def check_file(xmf, f, case):
    name = os.path.basename(xmf)
    g = f["snapshots"][case]
    snaps = [(s, float(g[s].attrs["time"])) for s in sorted(g) if int(g[s].attrs["contacts"]) > 0]
    reader = pv.Xdmf3ReaderS(FileName=[xmf])
    times = list(reader.TimestepValues) if len(snaps) > 1 else [snaps[0][1]]
    if len(times) != len(snaps) or any(t != s[1] for t, s in zip(times, snaps)):
        fail(f"{name}: {len(times)} time steps, run.h5 has {len(snaps)} snapshots with contacts of {case}")
    for s, t in snaps:
        reader.UpdatePipeline(t)
        d = leaf(sm.Fetch(reader))
        c = g[s]["contacts"]
        m = c["fn"].shape[0]
        where = f"{name} at t = {t} ({case} step {s})"
        if d.GetNumberOfCells() != m or d.GetNumberOfPoints() != 2 * m:
            fail(f"{where}: {d.GetNumberOfCells()} cells, {d.GetNumberOfPoints()} points; run.h5: {m} contacts")
        types = {d.GetCellType(k) for k in range(m)}
        if not types <= {3, 4} or any(d.GetCell(k).GetNumberOfPoints() != 2 for k in range(m)):
            fail(f"{where}: cell types {types}, expected 2-point lines")
        pts = vtk_to_numpy(d.GetPoints().GetData())
        ids = np.array([[d.GetCell(k).GetPointId(0), d.GetCell(k).GetPointId(1)] for k in range(m)])
        ends = c["ends"][()].reshape(m, 2, 3)
        if pts.dtype != np.float64 or not np.array_equal(pts[ids], ends):
            fail(f"{where}: the line ends ({pts.dtype}) differ from contacts/ends")
        for a, dt in ARRAYS.items():
            arr = d.GetCellData().GetArray(a)
            if arr is None:
                fail(f"{where}: no cell array {a}")
            v = vtk_to_numpy(arr)
            if v.dtype != dt or not np.array_equal(v, c[a][()]):
                fail(f"{where}: cell array {a} ({v.dtype}) differs from run.h5 ({c[a].dtype})")
    print(f"{name}: {len(snaps)} time steps; lines, ends and cell arrays {', '.join(ARRAYS)} equal run.h5")
    pv.Delete(reader)
    return xmf, snaps[-1][1], g[snaps[-1][0]]["contacts"]


def check_strong(xmf, t, c, png):
    reader = pv.Xdmf3ReaderS(FileName=[xmf])
    th = pv.Threshold(Input=reader)
    th.Scalars = ["CELLS", "strong"]
    if hasattr(th, "LowerThreshold"):
        th.LowerThreshold, th.UpperThreshold = 1, 1
    else:  # ParaView before 5.10
        th.ThresholdRange = [1, 1]
    th.UpdatePipeline(t)
    d = leaf(sm.Fetch(th))
    strong = c["strong"][()].astype(bool)
    fn = c["fn"][()]
    kept = np.sort(vtk_to_numpy(d.GetCellData().GetArray("fn")))
    if d.GetNumberOfCells() != int(strong.sum()) or not np.array_equal(kept, np.sort(fn[strong])):
        fail(f"Threshold strong = 1 kept {d.GetNumberOfCells()} cells, run.h5 has {int(strong.sum())} strong contacts")
    if strong.any() and (~strong).any() and fn[strong].min() <= fn[~strong].max():
        fail("a weak contact carries more normal force than a strong one")
    print(f"Threshold strong = 1: {d.GetNumberOfCells()} of {len(fn)} contacts, f_n {fn[strong].min():.4g} to "
          f"{fn[strong].max():.4g} N (weak below {fn[~strong].max():.4g} N)")
    if png is None:
        return
    view = pv.CreateView("RenderView")
    view.ViewSize = [800, 800]
    view.ViewTime = t
    view.Background = [1, 1, 1]
    if hasattr(view, "UseColorPaletteForBackground"):
        view.UseColorPaletteForBackground = 0
    view.OrientationAxesVisibility = 1
    tube = pv.Tube(Input=pv.ExtractSurface(Input=th))  # Tube takes poly data; Threshold gives a grid
    b = d.GetBounds()
    tube.Radius = 0.004 * max(b[1] - b[0], b[3] - b[2], b[5] - b[4])
    disp = pv.Show(tube, view)
    pv.ColorBy(disp, ("CELLS", "fn"))
    disp.SetScalarBarVisibility(view, True)
    bar = pv.GetScalarBar(pv.GetColorTransferFunction("fn"), view)
    bar.Title, bar.ComponentTitle = "f_n", "(N)"
    bar.TitleColor = bar.LabelColor = [0, 0, 0]
    c0 = [(b[0] + b[1]) / 2, (b[2] + b[3]) / 2, (b[4] + b[5]) / 2]
    view.CameraFocalPoint = c0
    view.CameraPosition = [c0[0], c0[1] - 3.0 * (b[3] - b[2] + b[1] - b[0]), c0[2]]
    view.CameraViewUp = [1, 0, 0]  # axis 1, the loading axis, upwards
    view.ResetCamera()
    pv.Render(view)
    pv.SaveScreenshot(png, view, ImageResolution=[800, 800])
    from paraview.vtk.vtkIOImage import vtkPNGReader
    r = vtkPNGReader()
    r.SetFileName(png)
    r.Update()
    img = vtk_to_numpy(r.GetOutput().GetPointData().GetScalars())[:, :3].astype(int)
    coloured = np.count_nonzero(np.abs(img - img[0]).sum(axis=1) > 30) / len(img)
    if coloured < 0.02:
        fail(f"{png}: blank image ({coloured:.1%} of the pixels differ from the background)")
    print(f"rendered {png}: {os.path.getsize(png)} bytes, {coloured:.0%} of the pixels show strong chains")


def main():
    args = sys.argv[1:]
    if not args:
        sys.exit(__doc__)
    out = os.path.abspath(args[0])
    png = os.path.abspath(args[args.index("--png") + 1]) if "--png" in args else os.path.join(out, "paraview_strong.png")
    if "--no-render" in args:
        png = None
    print(sm.vtkSMProxyManager.GetParaViewSourceVersion())
    f = h5py.File(os.path.join(out, "run.h5"), "r")
    cases = sorted(f["snapshots"])
    os.chdir("/")  # run.h5 must be found relative to the xmf file
    files = {c: os.path.join(out, f"run_{c}_contacts.xmf" if len(cases) > 1 else "run_contacts.xmf") for c in cases}
    last = None
    for c, xmf in files.items():
        if not os.path.exists(xmf):
            fail(f"{xmf} missing")
        last = check_file(xmf, f, c)
    check_strong(*last, png)
    print("check_paraview_contacts.py: OK")


if __name__ == "__main__":
    main()
