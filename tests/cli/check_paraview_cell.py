"""Opens the cell's XDMF sidecar of a sheared run in ParaView and checks it against run.h5.

    pvpython check_paraview_cell.py OUT [--png FILE] [--no-render]

OUT holds a run whose cell is sheared (issue 42): run.h5, run.xmf and run_cell.xmf (one case;
the test's is tests/io/test_run_output.cpp RunOutputSheared, simple shear past a flip). With
ParaView's Xdmf3 reader (Xdmf3ReaderS), from another working directory:
  - run_cell.xmf has one time step per snapshot, at the snapshot's time, as run.xmf;
  - at every time step: 8 points, the corners H s (s in {0, 1}^3) of the snapshot's
    cell_matrix H in run.h5, exactly (float64), and 12 cells, each a 2-point line along one
    edge vector (the cell array 'edge' names which: 1, 2, 3), between corners that differ by
    that edge vector: the slanted box;
  - run.xmf at the same time steps: every particle's point (= run.h5's position) lies in that
    box (fractional coordinates H^-1 x within 0.02 of [0, 1): the drift since the last wrap);
  - unless --no-render: the last snapshot's box (Tube, green) and spheres (Glyph, radius) seen
    along axis 3 rendered to a PNG, which must show the spheres and the box's edges.
Exits 0 if all hold, 1 (with the reason) otherwise, 77 (ctest: skipped) without h5py or numpy.
"""
import os
import sys

try:
    import h5py
    import numpy as np
except ImportError as e:
    print(f"check_paraview_cell.py: skipped: {e} (install python3-h5py and python3-numpy)")
    sys.exit(77)

from paraview import servermanager as sm
from paraview import simple as pv
from paraview.vtk.util.numpy_support import vtk_to_numpy


def fail(msg):
    print(f"check_paraview_cell.py: FAIL: {msg}")
    sys.exit(1)


def dataset(reader, t):
    reader.UpdatePipeline(t)
    d = sm.Fetch(reader)
    if d.IsA("vtkCompositeDataSet"):
        it = d.NewIterator()
        it.InitTraversal()
        d = it.GetCurrentDataObject()
    return d


def check(out):
    f = h5py.File(os.path.join(out, "run.h5"), "r")
    cases = sorted(f["snapshots"])
    if len(cases) != 1:
        fail(f"expected one case, run.h5 has {cases}")
    snaps = [f["snapshots"][cases[0]][s] for s in sorted(f["snapshots"][cases[0]])]
    os.chdir("/")  # run.h5 must be found relative to the xmf files
    cell = pv.Xdmf3ReaderS(FileName=[os.path.join(out, "run_cell.xmf")])
    parts = pv.Xdmf3ReaderS(FileName=[os.path.join(out, "run.xmf")])
    for r in (cell, parts):
        r.UpdatePipelineInformation()
    times = [float(t) for t in cell.TimestepValues]
    if times != [float(g.attrs["time"]) for g in snaps] or times != [float(t) for t in parts.TimestepValues]:
        fail(f"run_cell.xmf: {len(times)} time steps, not the {len(snaps)} snapshot times of run.h5 and run.xmf")
    sheared = 0
    for g, t in zip(snaps, times):
        where = f"run_cell.xmf at t = {t}"
        h = np.asarray(g.attrs["cell_matrix"], dtype=np.float64).reshape(3, 3)
        sheared += bool((h[~np.eye(3, dtype=bool)] != 0).any())
        d = dataset(cell, t)
        x = vtk_to_numpy(d.GetPoints().GetData())
        want = np.array([(k & 1) * h[:, 0] + ((k >> 1) & 1) * h[:, 1] + ((k >> 2) & 1) * h[:, 2] for k in range(8)])
        if x.dtype != np.float64 or not np.array_equal(x, want):
            fail(f"{where}: points {x.tolist()} ({x.dtype}) are not the corners H s {want.tolist()}")
        edge = vtk_to_numpy(d.GetCellData().GetArray("edge"))
        if d.GetNumberOfCells() != 12 or sorted(edge.tolist()) != [1] * 4 + [2] * 4 + [3] * 4:
            fail(f"{where}: {d.GetNumberOfCells()} cells, edge array {edge.tolist()}")
        for c in range(12):
            ids = d.GetCell(c).GetPointIds()
            if d.GetCell(c).GetNumberOfPoints() != 2:
                fail(f"{where}: cell {c} has {d.GetCell(c).GetNumberOfPoints()} points, a line has 2")
            a, b = x[ids.GetId(0)], x[ids.GetId(1)]
            if not np.allclose(b - a, h[:, edge[c] - 1], rtol=0, atol=1e-15 * np.abs(h).max()):
                fail(f"{where}: line {c} runs {b - a}, not along edge vector {edge[c]} = {h[:, edge[c] - 1]}")
        p = vtk_to_numpy(dataset(parts, t).GetPoints().GetData())
        if not np.array_equal(p, g["particles/position"][()]):
            fail(f"run.xmf at t = {t}: the points are not run.h5's positions")
        s = np.linalg.solve(h, p.T).T
        if s.min() < -0.02 or s.max() > 1.02:
            fail(f"run.xmf at t = {t}: particles outside the cell (fractional coordinates {s.min()} to {s.max()})")
    if sheared == 0:
        fail("no snapshot of run.h5 has a sheared cell")
    print(f"run_cell.xmf: {len(times)} time steps = snapshots ({sheared} sheared); every step: the 8 corners H s "
          f"exactly, 12 lines along the edge vectors; run.xmf's particles inside the slanted box")
    return cell, parts, times[-1]


def render(cell, parts, t, png):
    """The spheres (half transparent) and the box's edges (flat green tubes), seen along axis 3:
    the sheared box shows as a parallelogram."""
    view = pv.CreateView("RenderView")
    view.ViewSize = [800, 600]
    view.ViewTime = t
    view.Background = [1, 1, 1]
    if hasattr(view, "UseColorPaletteForBackground"):
        view.UseColorPaletteForBackground = 0
    glyph = pv.Glyph(Input=parts, GlyphType="Sphere")
    glyph.ScaleArray = ["POINTS", "radius"]
    glyph.OrientationArray = ["POINTS", "No orientation array"]
    glyph.ScaleFactor = 2.0
    glyph.GlyphMode = "All Points"
    spheres = pv.Show(glyph, view)
    pv.ColorBy(spheres, ("POINTS", "radius"))
    spheres.Opacity = 0.5
    b = cell.GetDataInformation().GetBounds()
    tube = pv.Tube(Input=pv.ExtractSurface(Input=cell), Radius=0.01 * (b[3] - b[2]))
    box = pv.Show(tube, view)
    box.ColorArrayName = ["POINTS", ""]
    box.AmbientColor = box.DiffuseColor = [0, 1, 0]
    box.Ambient, box.Diffuse = 1.0, 0.0  # flat: the pixels of the box are pure green
    c = [(b[0] + b[1]) / 2, (b[2] + b[3]) / 2, (b[4] + b[5]) / 2]
    view.CameraFocalPoint = c
    view.CameraPosition = [c[0], c[1], c[2] + 10 * (b[5] - b[4])]
    view.CameraViewUp = [0, 1, 0]
    view.ResetCamera()
    pv.Render(view)
    pv.SaveScreenshot(png, view, ImageResolution=[800, 600])
    from paraview.vtk.vtkIOImage import vtkPNGReader
    r = vtkPNGReader()
    r.SetFileName(png)
    r.Update()
    img = vtk_to_numpy(r.GetOutput().GetPointData().GetScalars())[:, :3].astype(int)
    green = np.count_nonzero((img[:, 1] > 200) & (img[:, 0] < 60) & (img[:, 2] < 60)) / len(img)
    coloured = np.count_nonzero(np.abs(img - img[0]).sum(axis=1) > 30) / len(img)
    if coloured < 0.05 or green < 0.002:
        fail(f"{png}: blank image or no box ({coloured:.1%} of the pixels differ from the background, "
             f"{green:.2%} the box's green)")
    print(f"rendered {png}: {coloured:.0%} of the pixels show spheres or the box ({green:.1%} the box's edges)")


def main():
    args = sys.argv[1:]
    if not args:
        sys.exit(__doc__)
    out = os.path.abspath(args[0])
    png = os.path.abspath(args[args.index("--png") + 1]) if "--png" in args else os.path.join(out, "paraview_cell.png")
    cell, parts, t = check(out)
    if "--no-render" in args:
        print("rendering skipped (--no-render)")
    else:
        render(cell, parts, t, png)
    print("check_paraview_cell.py: OK")


if __name__ == "__main__":
    main()
