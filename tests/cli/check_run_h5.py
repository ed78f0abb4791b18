#!/usr/bin/python3
"""Independent checks of a run's output (OUT/run.h5, OUT/run.xmf) with h5py, for ctest.

    check_run_h5.py same A/run.h5 B/run.h5   snapshots equal bit for bit (every dataset and
                                             attribute), series: step and stage equal, the
                                             other columns within 1e-9 of the column's largest
                                             magnitude (reductions sum in rank-dependent order)
    check_run_h5.py xdmf OUT                 run.xmf (and run_<case>.xmf for each case if
                                             several) is well-formed XML, lists every snapshot
                                             of run.h5 (of the case), every DataItem names an
                                             existing dataset of the stated dimensions, and the
                                             connectivity is a hyperslab 0..N-1 of /xdmf/vertices;
                                             the contacts' files likewise; and the cell's files
                                             run_cell.xmf (run_<case>_cell.xmf) exactly when a
                                             snapshot's cell_matrix is sheared: a grid per
                                             snapshot at its time, 12 two-node lines between the
                                             8 corners H s, equal to the stored H bit for bit
    check_run_h5.py foreign FILE             writes an HDF5 file without Fabrica's attributes
    check_run_h5.py readable FILE MIN        opens FILE and reads every dataset of every listed
                                             snapshot; prints how many; fails below MIN

Exits 77 (ctest: skipped) with a message when /usr/bin/python3 lacks h5py or numpy.
"""
import os
import sys
import xml.etree.ElementTree as ET

try:
    import h5py
    import numpy as np
except ImportError as e:
    print(f"check_run_h5.py: skipped: {e} (install python3-h5py and python3-numpy)")
    sys.exit(77)


def fail(msg):
    print(f"check_run_h5.py: FAIL: {msg}")
    sys.exit(1)


def same(pa, pb):
    a, b = h5py.File(pa, "r"), h5py.File(pb, "r")
    snaps = 0

    def cmp_snap(name, x):
        nonlocal snaps
        y = b.get("snapshots/" + name)
        if y is None:
            fail(f"{pb}: no /snapshots/{name}")
        for k, v in x.attrs.items():
            if not np.array_equal(v, y.attrs[k]):
                fail(f"/snapshots/{name} attribute {k}: {v} != {y.attrs[k]}")
        if isinstance(x, h5py.Dataset):
            u, w = x[()], y[()]
            if u.shape != w.shape or u.dtype != w.dtype or u.tobytes() != w.tobytes():
                fail(f"/snapshots/{name}: differs")
            snaps += 1

    a["snapshots"].visititems(cmp_snap)
    if sorted(_walk(a["snapshots"])) != sorted(_walk(b["snapshots"])):
        fail("the two files hold different snapshots")
    rows = 0
    worst = 0.0
    if sorted(a["series"]) != sorted(b["series"]):
        fail(f"series cases differ: {sorted(a['series'])} vs {sorted(b['series'])}")
    for c in a["series"]:
        ga, gb = a["series"][c], b["series"][c]
        if sorted(ga) != sorted(gb):
            fail(f"series {c}: columns differ")
        for k in ga:
            u, w = ga[k][()], gb[k][()]
            if u.shape != w.shape:
                fail(f"series {c}/{k}: {u.shape} rows vs {w.shape}")
            if k in ("step", "stage", "time"):
                if not np.array_equal(u, w):
                    fail(f"series {c}/{k} differs")
            else:
                scale = max(np.abs(u).max(initial=0), 1e-300)
                err = np.abs(u - w).max(initial=0) / scale
                worst = max(worst, err)
                if err > 1e-9:
                    fail(f"series {c}/{k}: relative difference {err:.3e} > 1e-9")
        rows += ga["step"].shape[0]
    print(f"same: {snaps} snapshot datasets bit for bit; {rows} series rows, largest relative "
          f"difference {worst:.2e} (tolerance 1e-9)")


def _walk(g, prefix=""):
    out = []
    for k, v in g.items():
        p = prefix + "/" + k
        out.append(p)
        if isinstance(v, h5py.Group):
            out += _walk(v, p)
    return out


def xdmf(outdir):
    h5 = os.path.join(outdir, "run.h5")
    f = h5py.File(h5, "r")
    cases = sorted(f["snapshots"])
    files = {"run.xmf": cases}
    if len(cases) > 1:
        files.update({f"run_{c}.xmf": [c] for c in cases})
    for name, cs in files.items():
        _xdmf_file(os.path.join(outdir, name), h5, f, cs)
    contacts = {"run_contacts.xmf": cases}
    if len(cases) > 1:
        contacts.update({f"run_{c}_contacts.xmf": [c] for c in cases})
    for name, cs in contacts.items():
        _contacts_xmf_file(os.path.join(outdir, name), h5, f, cs)
    cells = {"run_cell.xmf": cases}
    if len(cases) > 1:
        cells.update({f"run_{c}_cell.xmf": [c] for c in cases})
    sheared = any((_matrix(g)[~np.eye(3, dtype=bool)] != 0).any() for c in cases for g in f["snapshots"][c].values())
    for name, cs in cells.items():
        path = os.path.join(outdir, name)
        if not sheared:
            if os.path.exists(path):
                fail(f"{path}: a cell sidecar in a run whose cells are all orthorhombic")
            continue
        _cell_xmf_file(path, h5, f, cs)


def _matrix(g):
    """A snapshot's cell matrix H (3, 3): its attribute cell_matrix, else diag(cell_lengths)."""
    if "cell_matrix" in g.attrs:
        return np.asarray(g.attrs["cell_matrix"], dtype=np.float64).reshape(3, 3)
    return np.diag(np.asarray(g.attrs["cell_lengths"], dtype=np.float64))


EDGES = [0, 1, 2, 3, 4, 5, 6, 7, 0, 2, 1, 3, 4, 6, 5, 7, 0, 4, 1, 5, 2, 6, 3, 7]


def _cell_xmf_file(xmf, h5, f, cases):
    """The cell's sidecar: per snapshot 12 two-node Polyline cells on the 8 corners H s."""
    try:
        root = ET.parse(xmf).getroot()
    except (ET.ParseError, OSError) as e:
        fail(f"{xmf}: not well-formed XML: {e}")
    grids = [g for g in root.iter("Grid") if g.get("GridType") == "Uniform"]
    stored = [(c, s) for c in cases for s in sorted(f["snapshots"][c])]
    if len(grids) != len(stored):
        fail(f"{xmf}: {len(grids)} grids, {h5} holds {len(stored)} snapshots of case(s) {', '.join(cases)}")
    for grid, (c, s) in zip(grids, stored):
        g = f[f"snapshots/{c}/{s}"]
        where = f"{xmf}: grid {grid.get('Name')}"
        if grid.get("Name") != f"{c}_cell_{s}" or float(grid.find("Time").get("Value")) != float(g.attrs["time"]):
            fail(f"{where}: not snapshot {c}/{s} at its time {g.attrs['time']}")
        topo = grid.find("Topology")
        if (topo.get("TopologyType"), topo.get("NumberOfElements"), topo.get("NodesPerElement")) != \
                ("Polyline", "12", "2") or [int(v) for v in topo.find("DataItem").text.split()] != EDGES:
            fail(f"{where}: topology {topo.attrib}, connectivity {topo.find('DataItem').text}")
        geo = grid.find("Geometry/DataItem")
        corners = np.array([float(v) for v in geo.text.split()]).reshape(8, 3)
        h = _matrix(g)
        want = np.array([(k & 1) * h[:, 0] + ((k >> 1) & 1) * h[:, 1] + ((k >> 2) & 1) * h[:, 2] for k in range(8)])
        if geo.get("Dimensions") != "8 3" or not np.array_equal(corners, want):
            fail(f"{where}: corners {corners.tolist()}, the cell matrix gives {want.tolist()}")
    print(f"xdmf: {os.path.basename(xmf)} well-formed; the cells of {len(grids)} snapshots, corners H s exact")


CELL_ARRAYS = {"fn": ("Float", "8"), "ft_norm": ("Float", "8"), "mr_norm": ("Float", "8"),
               "sliding": ("UChar", "1"), "rolling": ("UChar", "1"), "strong": ("UChar", "1"),
               "id1": ("Int", "8"), "id2": ("Int", "8")}


def _contacts_xmf_file(xmf, h5, f, cases):
    """The contacts' sidecar: M two-node Polyline cells on contacts/ends, the cell arrays."""
    try:
        root = ET.parse(xmf).getroot()
    except (ET.ParseError, OSError) as e:
        fail(f"{xmf}: not well-formed XML: {e}")
    listed = set()
    for grid in root.iter("Grid"):
        if grid.get("GridType") != "Uniform":
            continue
        topo = grid.find("Topology")
        m = int(topo.get("NumberOfElements"))
        if topo.get("TopologyType") != "Polyline" or topo.get("NodesPerElement") != "2":
            fail(f"{xmf}: topology {topo.get('TopologyType')}, {topo.get('NodesPerElement')} nodes per element")
        slab = topo.find("DataItem")
        sel, src = slab.findall("DataItem")
        if [int(v) for v in sel.text.split()] != [0, 1, 2 * m] or slab.get("Dimensions") != f"{m} 2":
            fail(f"{xmf}: grid {grid.get('Name')}: connectivity {sel.text} / {slab.get('Dimensions')} for {m} lines")
        v = f[src.text.strip().split(":", 1)[1]][()]
        if v.shape[0] < 2 * m or not np.array_equal(v[:2 * m], np.arange(2 * m)):
            fail(f"{xmf}: the vertex index is not 0, 1, ... of at least {2 * m} values")
        geo = grid.find("Geometry/DataItem")
        base = geo.text.strip().split(":", 1)[1].rsplit("/", 1)[0]
        if not geo.text.strip().endswith("/contacts/ends") or f[base + "/ends"].shape != (m, 6) or \
                geo.get("Dimensions") != f"{m} 6":
            fail(f"{xmf}: grid {grid.get('Name')}: geometry {geo.text} {geo.get('Dimensions')}")
        names = {}
        for a in grid.findall("Attribute"):
            item = a.find("DataItem")
            path = item.text.strip().split(":", 1)[1]
            if a.get("Center") != "Cell" or path != f"{base}/{a.get('Name')}" or path not in f or \
                    f[path].shape != (m,) or item.get("Dimensions") != str(m):
                fail(f"{xmf}: attribute {a.get('Name')}: {a.get('Center')}, {path}, {item.get('Dimensions')}")
            names[a.get("Name")] = (item.get("NumberType"), item.get("Precision"))
        if names != CELL_ARRAYS:
            fail(f"{xmf}: grid {grid.get('Name')}: cell attributes {names}")
        if int(f[base.rsplit("/", 1)[0]].attrs["contacts"]) != m:
            fail(f"{xmf}: {m} lines, the snapshot has {f[base.rsplit('/', 1)[0]].attrs['contacts']} contacts")
        listed.add(base.rsplit("/", 1)[0])
    stored = {f"/snapshots/{c}/{s}" for c in cases for s in f["snapshots"][c]
              if int(f["snapshots"][c][s].attrs["contacts"]) > 0}
    if listed != stored:
        fail(f"{xmf} lists {len(listed)} snapshots, {h5} holds {len(stored)} with contacts of case(s) {', '.join(cases)}")
    print(f"xdmf: {os.path.basename(xmf)} well-formed; {len(listed)} snapshots with contacts, all present in {h5}")


def _xdmf_file(xmf, h5, f, cases):
    try:
        root = ET.parse(xmf).getroot()
    except (ET.ParseError, OSError) as e:
        fail(f"{xmf}: not well-formed XML: {e}")
    if root.tag != "Xdmf" or root.get("Version") != "3.0":
        fail(f"{xmf}: root is {root.tag} version {root.get('Version')}")
    listed = set()
    items = 0
    for grid in root.iter("Grid"):
        if grid.get("GridType") != "Uniform":
            continue
        topo = grid.find("Topology")
        n = int(topo.get("NumberOfElements"))
        if topo.get("TopologyType") != "Polyvertex" or topo.get("NodesPerElement") != "1":
            fail(f"{xmf}: topology {topo.get('TopologyType')}, {topo.get('NodesPerElement')} nodes per element")
        # The connectivity: a hyperslab (start 0, stride 1, count N) of /xdmf/vertices = 0, 1, ...
        slab = topo.find("DataItem")
        if slab is None or slab.get("ItemType") != "HyperSlab" or len(slab.findall("DataItem")) != 2:
            fail(f"{xmf}: grid {grid.get('Name')}: the topology has no HyperSlab connectivity")
        sel, src = slab.findall("DataItem")
        if [int(v) for v in sel.text.split()] != [0, 1, n] or int(slab.get("Dimensions")) != n:
            fail(f"{xmf}: grid {grid.get('Name')}: connectivity hyperslab {sel.text} for {n} points")
        vpath = src.text.strip().split(":", 1)[1]
        v = f[vpath][()] if vpath in f else None
        if v is None or v.shape != (int(src.get("Dimensions")),) or v.shape[0] < n or \
                not np.array_equal(v[:n], np.arange(n)):
            fail(f"{xmf}: {vpath} is not 0, 1, ... of at least {n} values as the XDMF says")
        names = {a.get("Name") for a in grid.findall("Attribute")}
        if not {"radius", "velocity", "id"} <= names:
            fail(f"{xmf}: grid {grid.get('Name')} lacks radius/velocity/id: {names}")
        float(grid.find("Time").get("Value"))
        for parent in [grid.find("Geometry")] + grid.findall("Attribute"):
            for item in parent.iter("DataItem"):
                fname, path = item.text.strip().split(":", 1)
                if fname != "run.h5":
                    fail(f"{xmf}: DataItem refers to {fname}")
                if path not in f:
                    fail(f"{xmf}: {path} does not exist in {h5}")
                dims = tuple(int(x) for x in item.get("Dimensions").split())
                if f[path].shape != dims or dims[0] != n:
                    fail(f"{xmf}: {path} has shape {f[path].shape}, the XDMF says {dims}")
                dt = f[path].dtype
                want = ("Float" if dt.kind == "f" else "Int" if dt.kind == "i"
                        else "UChar" if dt.itemsize == 1 else "UInt", str(dt.itemsize))
                if (item.get("NumberType"), item.get("Precision")) != want:
                    fail(f"{xmf}: {path} is {dt}, the XDMF says NumberType {item.get('NumberType')} "
                         f"Precision {item.get('Precision')}")
                items += 1
                listed.add(path.split("/particles/")[0])
    stored = {f"/snapshots/{c}/{s}" for c in cases for s in f["snapshots"][c]}
    if listed != stored:
        fail(f"{xmf} lists {len(listed)} snapshots, {h5} holds {len(stored)} of case(s) {', '.join(cases)}")
    print(f"xdmf: {os.path.basename(xmf)} well-formed; {len(listed)} snapshots, {items} DataItems, all present in {h5}")


def readable(path, minimum):
    f = h5py.File(path, "r")
    if "fabrica_version" not in f.attrs:
        fail(f"{path}: no fabrica_version")
    n = 0
    for c in f["snapshots"]:
        for s in f["snapshots"][c]:
            g = f["snapshots"][c][s]
            for sub in ("particles", "contacts"):
                for k in g[sub]:
                    g[sub][k][()]
            n += 1
    print(f"readable: {n} snapshots of {path} read completely")
    if n < minimum:
        fail(f"only {n} snapshots readable, expected at least {minimum}")


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    cmd = sys.argv[1]
    if cmd == "same":
        same(sys.argv[2], sys.argv[3])
    elif cmd == "xdmf":
        xdmf(sys.argv[2])
    elif cmd == "foreign":
        with h5py.File(sys.argv[2], "w") as f:
            f["data"] = np.arange(10)
    elif cmd == "readable":
        readable(sys.argv[2], int(sys.argv[3]))
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main()
