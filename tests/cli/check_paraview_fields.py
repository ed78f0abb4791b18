"""Opens the coarse-grained fields' sidecar (FIELDS.xmf, written by `fabrica fields` beside
FIELDS.h5, one sidecar per case, docs/fields.md) in ParaView and checks it against FIELDS.h5 (read with h5py):

    pvpython check_paraview_fields.py FIELDS_<case>.xmf [--png FILE] [--no-render]

With ParaView's Xdmf3 reader (Xdmf3ReaderS), from another working directory, for that case:
  - one time step per instant of the case, at the instant's time;
  - at every time step an image grid of nx x ny x nz points at origin + (i, j, k) spacing; for a
    case whose cell shears (its instants hold node_position, docs/fields.md "A sheared cell"), a
    structured grid whose points are node_position, x varying fastest, each at
    H ((i, j, k) + 1/2) / (nx, ny, nz) (relative 1e-12), H the instant's cell_matrix;
  - the point arrays solid_fraction (1 component), velocity (3) and contact_stress (9) equal the
    HDF5 datasets (compared with ==, NaN where NaN), x varying fastest;
  - unless --no-render: a slice through the middle of the cell coloured by solid_fraction, saved
    as a PNG that must not be blank.
Exits 0 if all hold, 1 with the reason otherwise, 77 if h5py or numpy is missing.
"""
import os
import sys

try:
    import h5py
    import numpy as np
except ImportError as e:
    print(f"check_paraview_fields.py: skipped: {e} (install python3-h5py and python3-numpy)")
    sys.exit(77)

from paraview import servermanager as sm
from paraview import simple as pv
from paraview.vtk.util.numpy_support import vtk_to_numpy

ARRAYS = {"solid_fraction": 1, "velocity": 3, "contact_stress": 9}


def fail(msg):
    print(f"check_paraview_fields.py: FAIL: {msg}")
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


def check_image(d, a, n, where):
    """An image grid at origin + (i, j, k) spacing (its bounds)."""
    b = d.GetBounds()
    o, h = a["origin"], a["spacing"]
    want = [o[0], o[0] + (n[0] - 1) * h[0], o[1], o[1] + (n[1] - 1) * h[1], o[2], o[2] + (n[2] - 1) * h[2]]
    if not np.allclose(b, want, rtol=1e-12, atol=1e-15):
        fail(f"{where}: bounds {b}, expected {want}")


def main():
    args = sys.argv[1:]
    png = None
    if "--png" in args:
        k = args.index("--png")
        png = os.path.abspath(args[k + 1])
        del args[k:k + 2]
    render = "--no-render" not in args
    args = [a for a in args if a != "--no-render"]
    xmf = os.path.abspath(args[0])
    import xml.etree.ElementTree as ET
    first = ET.parse(xmf).getroot().find("Domain/Grid/Grid/Attribute/DataItem").text
    h5 = os.path.join(os.path.dirname(xmf), first.split(":")[0])
    os.chdir("/")  # the sidecar names the HDF5 file relative to itself
    with h5py.File(h5, "r") as f:
        cases = [c for c in sorted(f["fields"]) if xmf.endswith(f"_{c}.xmf")]
        if not cases and len(f["fields"]) == 1:
            cases = list(f["fields"])
        if len(cases) != 1:
            fail(f"{xmf}: give the sidecar of one case (<stem>_<case>.xmf)")
        case = cases[0]
        g = f["fields"][case]
        steps = sorted(g)
        times = [float(g[s].attrs["time"]) for s in steps]
        reader = pv.Xdmf3ReaderS(FileName=[xmf])
        got = list(reader.TimestepValues) if len(steps) > 1 else times
        if len(got) != len(steps) or any(abs(a - b) > 1e-12 * max(abs(b), 1) for a, b in zip(got, times)):
            fail(f"{len(got)} time steps, {h5} has {len(steps)} instants of {case}")
        sheared = 0
        for s, t in zip(steps, times):
            reader.UpdatePipeline(t)
            d = leaf(sm.Fetch(reader))
            a = g[s].attrs
            n = [int(x) for x in a["cells"]]
            where = f"{case} step {int(s)} (t = {t})"
            if d.GetNumberOfPoints() != n[0] * n[1] * n[2]:
                fail(f"{where}: {d.GetNumberOfPoints()} points, grid {n}")
            if "node_position" in g[s]:
                sheared += 1
                pts = vtk_to_numpy(d.GetPoints().GetData()).reshape(-1, 3)
                if not np.array_equal(pts, g[s]["node_position"][()].reshape(-1, 3)):
                    fail(f"{where}: the points differ from node_position")
                H = np.asarray(a["cell_matrix"], dtype=np.float64).reshape(3, 3)
                k, j, i = np.meshgrid(*[np.arange(m) for m in n[::-1]], indexing="ij")
                frac = np.stack([(i + 0.5) / n[0], (j + 0.5) / n[1], (k + 0.5) / n[2]], axis=-1).reshape(-1, 3)
                err = np.abs(pts - frac @ H.T).max() / np.abs(H).max()
                if not err <= 1e-12:
                    fail(f"{where}: a point is {err:.2e} (relative) from H ((i, j, k) + 1/2) / n")
            else:
                check_image(d, a, n, where)
            for name, comps in ARRAYS.items():
                arr = d.GetPointData().GetArray(name)
                if arr is None or arr.GetNumberOfComponents() != comps:
                    fail(f"{where}: no point array {name} of {comps} components")
                v = vtk_to_numpy(arr).reshape(-1)
                w = g[s][name][()].reshape(-1)
                if not np.array_equal(v, w, equal_nan=True):
                    fail(f"{where}: point array {name} differs from {h5}")
        print(f"{os.path.basename(xmf)}: {len(steps)} time steps of {case} ({sheared} structured grids at the "
              f"nodes' positions); grids and the point arrays {', '.join(ARRAYS)} equal the HDF5 file")
        if not render or png is None:
            return
        reader.UpdatePipeline(times[-1])
        view = pv.CreateView("RenderView")
        view.ViewSize = [800, 600]
        view.ViewTime = times[-1]
        view.Background = [1, 1, 1]
        if hasattr(view, "UseColorPaletteForBackground"):
            view.UseColorPaletteForBackground = 0
        sl = pv.Slice(Input=reader)
        sl.SliceType.Normal = [0, 0, 1]
        disp = pv.Show(sl, view)
        pv.ColorBy(disp, ("POINTS", "solid_fraction"))
        view.ResetCamera()
        pv.Render(view)
        pv.SaveScreenshot(png, view, ImageResolution=[800, 600])
        from paraview.vtk.vtkIOImage import vtkPNGReader
        r = vtkPNGReader()
        r.SetFileName(png)
        r.Update()
        img = vtk_to_numpy(r.GetOutput().GetPointData().GetScalars())
        if img.size == 0 or np.all(img == img[0]):
            fail(f"{png}: blank image")
        print(f"{png}: a slice coloured by solid_fraction")


main()
