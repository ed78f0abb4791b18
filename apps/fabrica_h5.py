"""Read a Fabrica run file ``OUT/run.h5`` into numpy arrays.

The layout is described in docs/output.md; this module is the Python counterpart of the C++
reader ``io/mpi/snapshot.hpp`` and returns the same values (checked by the test
``cli.output.python_reader`` against that reader on the same file)::

    import sys; sys.path.insert(0, "apps")
    import fabrica_h5
    run = fabrica_h5.RunFile("out/demo/run.h5")
    s = run.series("mur_0.2")                 # Series: s["eps1"], s["q_p"], s.step, s.stage
    last = run.snapshots("mur_0.2")[-1]       # SnapshotInfo: case, step, time, strain, cell_matrix, ...
    c = run.contacts("mur_0.2", last.step)    # Contacts: c.fn, c.normal, c.strong, ...
    strong_share = c.strong.mean()

Coarse-grained fields (docs/fields.md; ``fabrica fields OUT/run.h5`` writes ``OUT/fields.h5``)::

    fl = fabrica_h5.RunFile("out/demo/fields.h5")
    inst = fl.field_instants("mur_0.2")[-1]   # FieldsInfo: case, step, cells, spacing, kernel, ...
    f = fl.fields("mur_0.2", inst.step)       # dict: name -> array indexed [i, j, k(, a(, b))]
    phi = f["solid_fraction"]                 # (nx, ny, nz); f["stress"] is (nx, ny, nz, 3, 3)

Needs h5py and numpy (Debian's python3-h5py, python3-numpy; use /usr/bin/python3).
Every error (missing, damaged or foreign file, unknown case or step) is a
:class:`FabricaFileError` whose message names the file and the object.
"""
from dataclasses import dataclass, field

import numpy as np

try:
    import h5py
except ImportError as e:  # pragma: no cover
    raise ImportError(f"fabrica_h5: {e}; install python3-h5py and run with /usr/bin/python3") from e

__all__ = ["FabricaFileError", "RunFile", "RunInfo", "Series", "SnapshotInfo", "Particles", "Contacts",
           "FieldsInfo"]


NODE_POSITION = "node_position"  # a sheared grid's node positions in a field instant (not a field)


class FabricaFileError(Exception):
    """A run file that cannot be read as asked: the message names the file and the object."""


def _text(v):
    """A string attribute as str (fixed-length HDF5 strings arrive as bytes in h5py 3)."""
    return v.decode() if isinstance(v, bytes) else str(v)


@dataclass
class RunInfo:
    """The root attributes and the scene of a run file."""
    version: str       #: Fabrica's version that wrote the file
    git_describe: str  #: ``git describe`` of that build
    mpi_ranks: int     #: ranks that wrote the file
    scene_path: str    #: the scene file (``<built-in demo scene>`` for the default)
    scene_text: str    #: its text


@dataclass
class SnapshotInfo:
    """The attributes of one snapshot group ``/snapshots/<case>/<step>``."""
    case: str
    step: int
    time: float               #: s
    cell_lengths: np.ndarray  #: (3,) m (of a sheared cell: the diagonal of cell_matrix)
    strain: np.ndarray        #: (3,) eps_i = ln(l_i0 / l_i), compression positive
    particles: int
    contacts: int
    #: (W, 3) m and (W, 3): each wall's point of the plane at this step and its unit normal
    #: (empty (0, 3) without walls)
    wall_points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    wall_normals: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    #: (3, 3) m: the cell matrix H, its columns the edge vectors (a point of fractional
    #: coordinates s is H @ s); diag(cell_lengths) for an orthorhombic cell and in files written
    #: before the attribute ``cell_matrix``
    cell_matrix: np.ndarray = None

    def __post_init__(self):
        if self.cell_matrix is None:
            self.cell_matrix = np.diag(np.asarray(self.cell_lengths, dtype=np.float64))

    @property
    def sheared(self):
        """Whether the cell is sheared (its matrix has an off-diagonal term)."""
        return bool(np.any(self.cell_matrix[~np.eye(3, dtype=bool)] != 0))

    @property
    def volume(self):
        """The cell's volume, m^3: L1 L2 L3 (orthorhombic), |det H| (sheared)."""
        if self.sheared:
            return float(abs(np.linalg.det(self.cell_matrix)))
        return float(self.cell_lengths[0] * self.cell_lengths[1] * self.cell_lengths[2])

    def fractional(self, x):
        """Fractional coordinates s = H^-1 x of positions x (N, 3): in [0, 1) inside the cell."""
        return np.linalg.solve(self.cell_matrix, np.asarray(x, dtype=np.float64).T).T


@dataclass
class Particles:
    """The particles of one snapshot, in increasing id order (N rows)."""
    info: SnapshotInfo
    id: np.ndarray        #: (N,) int64
    position: np.ndarray  #: (N, 3) m
    velocity: np.ndarray  #: (N, 3) m/s
    spin: np.ndarray      #: (N, 3) rad/s
    radius: np.ndarray    #: (N,) m
    material: np.ndarray  #: (N,) uint8, the index of its [[material]] (0: one material)


@dataclass
class Contacts:
    """The contacts of one snapshot, each once, in (id1, id2) order (M rows).

    ``sliding``, ``rolling`` and ``strong`` are bool arrays: at the Coulomb limit, at the rolling
    limit, and f_n above ``[fabric] strong_ratio`` x the mean f_n of the snapshot (the
    classification of docs/fabric.md). ``ends`` (M, 2, 3) holds the centre of body 1 and the
    periodic image of body 2 next to it (x1 + branch): the line of the contact.
    """
    info: SnapshotInfo
    id1: np.ndarray      #: (M,) int64, id1 < id2 (a wall contact: id2 = -1 - wall index)
    id2: np.ndarray      #: (M,) int64
    normal: np.ndarray   #: (M, 3) unit normal from 1 to 2
    branch: np.ndarray   #: (M, 3) m, x2 (periodic image) - x1
    overlap: np.ndarray  #: (M,) m
    fn: np.ndarray       #: (M,) N, elastic normal force
    ft: np.ndarray       #: (M, 3) N, shear spring force on 2
    mr: np.ndarray       #: (M, 3) N m, rolling moment on 2
    sliding: np.ndarray  #: (M,) bool
    rolling: np.ndarray  #: (M,) bool
    strong: np.ndarray   #: (M,) bool
    ft_norm: np.ndarray  #: (M,) N, |f_t|
    mr_norm: np.ndarray  #: (M,) N m, |m_r|
    ends: np.ndarray     #: (M, 2, 3) m

    def __len__(self):
        return int(self.id1.shape[0])

    def network(self, name):
        """Boolean mask of one of the 15 networks of docs/fabric.md: ``all``, ``ns``, ``s``,
        ``r``, ``nr``, ``sf``, ``wf`` and the pairs ``ns-nr``, ``s-sf``, ... ."""
        tests = {"all": np.ones(len(self), bool), "s": self.sliding, "ns": ~self.sliding,
                 "r": self.rolling, "nr": ~self.rolling, "sf": self.strong, "wf": ~self.strong}
        parts = name.split("-")
        if not all(p in tests for p in parts) or len(parts) > 2:
            raise ValueError(f"fabrica_h5: unknown network {name!r}")
        mask = np.ones(len(self), bool)
        for p in parts:
            mask &= tests[p]
        return mask


class Series:
    """One series table ``/series/<case>``: a float64 array per CSV column.

    ``s["q_p"]`` is a column, ``s.columns`` the names in CSV order (without step and stage),
    ``s.step`` the int64 steps and ``s.stage`` the stage name of every row (empty list when the
    table has no stage column); ``s.rows(stage)`` the mask of one stage's rows.
    """

    def __init__(self, columns, values, step, stage):
        self.columns = list(columns)
        self._values = dict(zip(columns, values))
        self.step = step
        self.stage = stage

    def __getitem__(self, column):
        try:
            return self._values[column]
        except KeyError:
            raise KeyError(f"fabrica_h5: no column {column!r} (columns: {', '.join(self.columns)})") from None

    def __contains__(self, column):
        return column in self._values

    def __len__(self):
        return int(self.step.shape[0])

    def rows(self, stage):
        """Boolean mask of the rows of one stage (``consolidation``, ``equilibration``, ``shear``)."""
        return np.array([s == stage for s in self.stage], dtype=bool)


@dataclass
class FieldsInfo:
    """The attributes of one instant of coarse-grained fields ``/fields/<case>/<step>``."""
    case: str
    step: int
    time: float               #: s
    cell_lengths: np.ndarray  #: (3,) m
    cells: np.ndarray         #: (3,) int, nodes along x, y, z
    spacing: np.ndarray       #: (3,) m; node (i, j, k) at origin + (i, j, k) * spacing (orthorhombic)
    origin: np.ndarray        #: (3,) m, the first node (half a spacing from the cell's corner)
    kernel: str               #: "gaussian" or "lucy"
    width: float              #: m: the Gaussian's standard deviation, Lucy's support radius
    cutoff: float             #: the Gaussian's support radius in widths (1 for Lucy)
    names: list               #: the fields stored (dataset names)
    displacement_from_step: int = -1  #: the earlier snapshot of the displacement fields (-1: none)
    #: (3, 3) m, the cell matrix H (columns the edge vectors); diag(cell_lengths) unless sheared.
    #: A sheared grid's node (i, j, k) is at H ((i, j, k) + 1/2) / cells (its dataset node_position).
    cell_matrix: np.ndarray = None

    @property
    def sheared(self):
        """Whether the grid is cut in the fractional coordinates of a sheared cell."""
        return bool((self.cell_matrix[~np.eye(3, dtype=bool)] != 0).any())


class RunFile:
    """A Fabrica run file, opened read-only for each call (like the C++ reader)."""

    def __init__(self, path):
        self.path = str(path)
        with self._open() as f:
            if "fabrica_version" not in f.attrs:
                raise FabricaFileError(f"{self.path}: not a Fabrica output file (no fabrica_version attribute)")

    def _open(self):
        try:
            return h5py.File(self.path, "r")
        except FileNotFoundError:
            raise FabricaFileError(f"{self.path}: no such file") from None
        except OSError as e:
            raise FabricaFileError(f"{self.path}: cannot open the HDF5 file (truncated, damaged or not HDF5?): {e}") from None

    def _group(self, f, name, what):
        if name not in f:
            raise FabricaFileError(f"{self.path}: {what} (no group /{name})")
        return f[name]

    def info(self):
        """The version attributes and the scene (:class:`RunInfo`)."""
        with self._open() as f:
            scene = f["scene"] if "scene" in f else None
            return RunInfo(version=_text(f.attrs["fabrica_version"]),
                           git_describe=_text(f.attrs.get("git_describe", b"unknown")),
                           mpi_ranks=int(f.attrs.get("mpi_ranks", 0)),
                           scene_path=_text(scene.attrs.get("path", b"")) if scene is not None else "",
                           scene_text=_text(scene[()]) if scene is not None else "")

    def series_cases(self):
        """The cases with a series table, in name order."""
        with self._open() as f:
            return sorted(f["series"]) if "series" in f else []

    def series(self, case):
        """The series table of ``case`` (:class:`Series`)."""
        with self._open() as f:
            g = self._group(f, f"series/{case}", f"no series of case '{case}'")
            header = _text(g.attrs["columns"]).split(",")
            columns = [c for c in header if c not in ("step", "stage")]
            values = [g[c][()].astype(np.float64) for c in columns]
            stage = []
            if "stage" in g:
                labels = _text(g["stage"].attrs["labels"]).split(",")
                stage = [labels[k] for k in g["stage"][()]]
            return Series(columns, values, g["step"][()].astype(np.int64), stage)

    @staticmethod
    def _info(case, g):
        a = g.attrs
        # Files written before the cell matrix: None, then diag(cell_lengths) (__post_init__).
        h = np.asarray(a["cell_matrix"], dtype=np.float64).reshape(3, 3) if "cell_matrix" in a else None
        return SnapshotInfo(case=case, step=int(a["step"]), time=float(a["time"]),
                            cell_lengths=np.asarray(a["cell_lengths"], dtype=np.float64),
                            strain=np.asarray(a["strain"], dtype=np.float64),
                            particles=int(a["particles"]), contacts=int(a["contacts"]),
                            wall_points=np.asarray(a.get("wall_points", []), dtype=np.float64).reshape(-1, 3),
                            wall_normals=np.asarray(a.get("wall_normals", []), dtype=np.float64).reshape(-1, 3),
                            cell_matrix=h)

    def snapshots(self, case=None):
        """Every snapshot (:class:`SnapshotInfo`) of ``case``, or of every case (cases in name
        order), by step - the order of the C++ ``list_snapshots``."""
        with self._open() as f:
            if "snapshots" not in f:
                return []
            snaps = f["snapshots"]
            if case is not None and case not in snaps:
                raise FabricaFileError(f"{self.path}: no snapshots of case '{case}' (no group /snapshots/{case})")
            out = []
            for c in ([case] if case is not None else sorted(snaps)):
                out.extend(sorted((self._info(c, g) for g in snaps[c].values()), key=lambda s: s.step))
            return out

    def _snapshot(self, f, case, step):
        name = f"snapshots/{case}/{int(step):012d}"
        return self._group(f, name, f"no snapshot of case '{case}' at step {step}")

    def particles(self, case, step):
        """The particles of the snapshot of ``case`` at ``step`` (:class:`Particles`)."""
        with self._open() as f:
            g = self._snapshot(f, case, step)
            p = g["particles"]
            return Particles(info=self._info(case, g), id=p["id"][()], position=p["position"][()],
                             velocity=p["velocity"][()], spin=p["spin"][()], radius=p["radius"][()],
                             # files written before the materials hold one material
                             material=(p["material"][()] if "material" in p
                                       else np.zeros(len(p["id"]), dtype=np.uint8)))

    def contacts(self, case, step, strong_ratio=1.0):
        """The contacts of the snapshot of ``case`` at ``step`` (:class:`Contacts`).

        Files written before the strong flag, |f_t|, |m_r| and the ends were stored get them
        computed here (``strong_ratio`` x the mean f_n; ends from the particle positions)."""
        with self._open() as f:
            g = self._snapshot(f, case, step)
            c = g["contacts"]
            d = {k: c[k][()] for k in ("id1", "id2", "normal", "branch", "overlap", "fn", "ft", "mr")}
            d["normal"], d["branch"], d["ft"], d["mr"] = (d[k].reshape(-1, 3) for k in ("normal", "branch", "ft", "mr"))
            d["sliding"] = c["sliding"][()].astype(bool)
            d["rolling"] = c["rolling"][()].astype(bool)
            if "strong" in c:
                d["strong"] = c["strong"][()].astype(bool)
                d["ft_norm"], d["mr_norm"] = c["ft_norm"][()], c["mr_norm"][()]
                d["ends"] = c["ends"][()].reshape(-1, 2, 3)
            else:
                mean = d["fn"].mean() if d["fn"].size else 0.0
                d["strong"] = d["fn"] > strong_ratio * mean
                d["ft_norm"] = np.linalg.norm(d["ft"], axis=1)
                d["mr_norm"] = np.linalg.norm(d["mr"], axis=1)
                ids, pos = g["particles/id"][()], g["particles/position"][()]
                x1 = pos[np.searchsorted(ids, d["id1"])]
                d["ends"] = np.stack([x1, x1 + d["branch"]], axis=1)
            return Contacts(info=self._info(case, g), **d)

    @staticmethod
    def _fields_info(case, g):
        a = g.attrs
        return FieldsInfo(case=case, step=int(a["step"]), time=float(a["time"]),
                          cell_lengths=np.asarray(a["cell_lengths"], dtype=np.float64),
                          cells=np.asarray(a["cells"]).astype(np.int64),
                          spacing=np.asarray(a["spacing"], dtype=np.float64),
                          origin=np.asarray(a["origin"], dtype=np.float64),
                          kernel=_text(a["kernel"]), width=float(a["width"]), cutoff=float(a["cutoff"]),
                          names=sorted(n for n in g if n != NODE_POSITION),
                          displacement_from_step=int(a.get("displacement_from_step", -1)),
                          cell_matrix=(np.asarray(a["cell_matrix"], dtype=np.float64).reshape(3, 3) if "cell_matrix" in a
                                       else np.diag(np.asarray(a["cell_lengths"], dtype=np.float64))))

    def field_instants(self, case=None):
        """Every instant of coarse-grained fields (:class:`FieldsInfo`) of ``case``, or of every
        case (in name order), by step."""
        with self._open() as f:
            if "fields" not in f:
                return []
            fl = f["fields"]
            if case is not None and case not in fl:
                raise FabricaFileError(f"{self.path}: no fields of case '{case}' (no group /fields/{case})")
            out = []
            for c in ([case] if case is not None else sorted(fl)):
                out.extend(sorted((self._fields_info(c, g) for g in fl[c].values()), key=lambda s: s.step))
            return out

    def fields(self, case, step, names=None):
        """The fields of ``case`` at ``step`` (all, or ``names``) as a dict name -> array indexed
        [i, j, k] by the node along x, y, z: scalars (nx, ny, nz), vectors (nx, ny, nz, 3),
        tensors (nx, ny, nz, 3, 3) (row a, column b). The file stores them (nz, ny, nx[, c])."""
        with self._open() as f:
            g = self._group(f, f"fields/{case}/{int(step):012d}", f"no fields of case '{case}' at step {step}")
            out = {}
            for name in (names if names is not None else sorted(n for n in g if n != NODE_POSITION)):
                if name not in g:
                    raise FabricaFileError(f"{self.path}: no field '{name}' of case '{case}' at step {step}")
                v = g[name][()]
                v = np.swapaxes(v, 0, 2)  # (nx, ny, nz[, c])
                if v.ndim == 4 and v.shape[3] == 9:
                    v = v.reshape(v.shape[:3] + (3, 3))
                out[name] = v
            return out
