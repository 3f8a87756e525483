"""mchex: all-hex meshes of a solid and of the box around it (MCHex, Tong & Zhang 2025), from Python.

The same pipeline as the command line program mchex-gpu, in process (docs/python.md):

    import mchex
    r = mchex.mesh("bunny.stl", hausdorff=0.01)      # or mchex.mesh(shape="sphere", depth=3)
    r.inside.points, r.inside.hexes, r.inside.region  # numpy: float64 N x 3, int64 M x 8, int32 M
    r.report["check"]["ok"]                           # the report `mchex-gpu mesh --report` writes
    r.write("inside.vtu")                             # and outside.vtu beside it
    mchex.check(r.inside, r.outside)                  # the JSON of `mchex-gpu check --json`

The options of mesh() are those of `mchex-gpu mesh`, with '_' for '-' (max_depth=5 is
--max-depth 5; fidelity=False is --no-fidelity; repair=False is --no-repair), checked by the same
code with the same one-line messages. Bad input raises InputError (a ValueError), a run over its
memory budget ResourceError, a mesh that fails its own check CheckError; the GIL is released
while the work runs, so other Python threads go on.
"""
import json
import os

import numpy as np

from . import _mchex
from ._mchex import InputError, ResourceError

__all__ = ["mesh", "check", "certify", "devices", "backends", "from_meshio", "Mesh", "Result",
           "InputError", "ResourceError", "CheckError"]


class CheckError(RuntimeError):
    """A mesh failed its own check (exit 3 in the CLI): nothing is returned, `report` says why."""

    def __init__(self, message, report):
        super().__init__(message)
        self.report = report


class Mesh:
    """An all-hex mesh: points (float64 N x 3), hexes (int64 M x 8, VTK_HEXAHEDRON corner order)
    and region (int32 M: 1 inside, 2 outside, or 1..k and k + 1 with k regions, as the files'
    cell data)."""

    def __init__(self, points, hexes, region=None):
        self.points = np.ascontiguousarray(points, dtype=np.float64)
        self.hexes = np.ascontiguousarray(hexes, dtype=np.int64)
        self.region = None if region is None else np.ascontiguousarray(region, dtype=np.int32)

    def __repr__(self):
        return f"mchex.Mesh({len(self.hexes)} hexes, {len(self.points)} points)"

    def _arrays(self):
        return (self.points, self.hexes, self.region)

    def write(self, path, binary=False):
        """Writes the mesh; the format follows the extension (.mesh, .meshb, .vtu, .msh, .exo, .inp);
        binary: .msh as Gmsh 4.1 binary."""
        _mchex.write(self._arrays(), None, os.fspath(path), "", binary)

    def to_meshio(self):
        """This mesh as a meshio.Mesh: one "hexahedron" block, the regions as cell data "region"."""
        import meshio
        region = self.region if self.region is not None else np.ones(len(self.hexes), np.int32)
        return meshio.Mesh(self.points, [("hexahedron", self.hexes)], cell_data={"region": [region]})


def from_meshio(m):
    """A Mesh from a meshio.Mesh's hexahedra (cell data "region" kept when it has it)."""
    hexes, region = [], []
    for i, block in enumerate(m.cells):
        if block.type != "hexahedron":
            continue
        hexes.append(np.asarray(block.data))
        data = m.cell_data.get("region")
        if data is not None:
            region.append(np.asarray(data[i]))
    if not hexes:
        raise InputError("from_meshio: the mesh has no hexahedron cells")
    return Mesh(m.points, np.concatenate(hexes), np.concatenate(region) if len(region) == len(hexes) else None)


class Result:
    """What mesh() returns: the inside and outside meshes (Mesh) and the run's report (dict)."""

    def __init__(self, inside, outside, report):
        self.inside, self.outside, self.report = inside, outside, report

    def __repr__(self):
        return f"mchex.Result(inside={self.inside!r}, outside={self.outside!r})"

    def write(self, path, outside=None, binary=False):
        """Writes both meshes, as `mchex-gpu mesh -o PATH --outside OUTSIDE` does: the outside mesh
        by default to outside.EXT beside PATH; every name is checked before either is written."""
        path = os.fspath(path)
        if outside is None:
            folder, name = os.path.split(path)
            outside = os.path.join(folder, "outside" + os.path.splitext(name)[1])
        _mchex.write(self.inside._arrays(), self.outside._arrays(), path, os.fspath(outside), binary)


def _mesh_of(arrays):
    points, hexes, region = arrays
    return Mesh(points, hexes, region)


def _surface_source(source):
    """A surface for _mchex.mesh: a path (str) or a (vertices, triangles) pair."""
    if isinstance(source, (str, os.PathLike)):
        return os.fspath(source)
    if isinstance(source, (tuple, list)):
        if len(source) != 2:
            raise InputError("source: expected a file name or a (vertices, triangles) pair")
        return tuple(source)
    raise InputError(f"source: expected a file name or a (vertices, triangles) pair, got {type(source).__name__}")


def mesh(source=None, *, shape=None, name="arrays", threads=None, quiet=True, **options):
    """Meshes a surface or a built-in shape; returns a Result.

    source: a surface file (str or path-like: STL, OBJ, OFF, PLY), or a (vertices, triangles)
    pair (float N x 3, integer M x 3; `name` is how the report names it), or a list of them: the
    regions of one conforming mesh, as several INPUT files of `mchex-gpu mesh` (each hex's region
    is its source's position, 1..k inside, k + 1 outside; region_order="2,1" and
    shells_as_regions=True as on the command line; arrays are named "NAME I"); shape: a built-in
    analytic shape (sphere, torus, rounded-box, two-holed); neither: the torus. options: those
    of `mchex-gpu mesh` with '_' for '-': depth, threshold, max_depth, hausdorff, max_hexes,
    method, eps, backend, pad, fidelity, lattice, optimize, sign, repair, max_memory, ...
    threads: worker threads (default all); quiet=False prints the CLI's progress lines and warnings.
    """
    if isinstance(source, list):
        if not source:
            raise InputError("source: an empty list (give one surface, or several: the regions of one mesh)")
        sources = [_surface_source(s) for s in source]
    else:
        sources = [] if source is None else [_surface_source(source)]
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, int) or not 1 <= threads <= 1024):
        raise InputError(f"--threads: Value {threads} not in range [1 - 1024]")
    out = _mchex.mesh(sources, shape or "", name, options, threads or 0, bool(quiet))
    report = json.loads(out["report"])
    if not out["ok"]:
        raise CheckError("the mesh fails its own check: " + out["error"], report)
    return Result(_mesh_of(out["inside"]), _mesh_of(out["outside"]), report)


def _mesh_source(m):
    if isinstance(m, (str, os.PathLike)):
        return os.fspath(m)
    if isinstance(m, Mesh):
        return m._arrays()
    if isinstance(m, tuple):
        return m
    raise InputError(f"expected a Mesh, a file name or (points, hexes), got {type(m).__name__}")


def check(inside, outside=None, input=None, *, quiet=True, **options):
    """Validates a hex mesh (and its outside mesh) as `mchex-gpu check --json` does and returns that
    JSON as a dict: "check" (structure, quality, conformity; "ok"), and with `input` (a surface file)
    or shape= (a built-in shape) "input" and "fidelity". inside, outside: a Mesh, a file name or
    (points, hexes). options: shape, sign, repair, lattice, as `check`'s."""
    text = _mchex.check(_mesh_source(inside), None if outside is None else _mesh_source(outside),
                        "" if input is None else os.fspath(input), options, bool(quiet))
    return json.loads(text)


def certify(eps=1e-3, types=None):
    """Re-checks the positivity proof, as `mchex-gpu certify --eps EPS [--type NAME ...]` (about
    2 minutes on 2 cores for every type): a dict with "passed", the per-cell-type summary ("types":
    hexes, proven subcases, the least coefficient, the subcases left to the run-time remedy), the
    first failure if any, and "text", the table the CLI prints. types: names of the cell types to
    certify (None: all; the single type is always certified)."""
    if isinstance(types, str):
        types = [types]
    return _mchex.certify(float(eps), [str(t) for t in (types or [])])


def devices():
    """The compute backends and devices found, as `mchex-gpu devices --json`: a list of dicts."""
    return json.loads(_mchex.devices())


def backends():
    """The names backend= accepts in this build ("auto", "cpu", then the device backends built)."""
    return list(_mchex.backends())
