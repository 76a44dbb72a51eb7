"""Writing results: VTU (ParaView) through meshio, ParaView time series, JSON summaries."""
from __future__ import annotations

import json
import math
import os
import tempfile
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from xml.sax.saxutils import quoteattr

import numpy as np

from .params import ParameterError

__all__ = ["write_result", "write_json", "check_writable", "whole_sheet_fields",
           "state_fields", "write_vtu", "Frame", "Series", "write_series", "read_pvd",
           "check_directory", "register_point_fields", "extra_point_fields",
           "atomic_write", "to_jsonable", "dumps_json", "in_units"]

#: Extra vertex fields of a solved state for the VTU of ``Result.write``:
#: callables ``(problem, w, points) -> {name: ndarray (n,) or (n, 3)}`` at the
#: whole sheet's reference vertices ``points`` (3, n), registered by higher
#: layers (this layer imports none of them): :mod:`skfem_sheet.analyses.midsurface`
#: adds the mid-surface fields u, v, w, E_ss, E_st, E_tt, T_ss/Y, T_tt/Y.
_POINT_FIELDS = []


def register_point_fields(provider) -> None:
    """Add ``provider(problem, w, points) -> dict`` to the fields of every result VTU."""
    if provider not in _POINT_FIELDS:
        _POINT_FIELDS.append(provider)


def extra_point_fields(problem, w, points) -> dict:
    """The registered providers' fields at ``points`` (3, n), merged in registration order."""
    out = {}
    for provider in _POINT_FIELDS:
        out.update(provider(problem, w, points))
    return out


def atomic_write(filename, data) -> None:
    """Write ``data`` (``str`` or ``bytes``) to ``filename`` atomically.

    The data go to a temporary file in the same folder, are flushed to disk and
    then renamed over ``filename`` (``os.replace``), so a reader never sees a
    half-written file, even when the writer is killed.  The one atomic write of
    the package: every table, cache and summary is written through it.

    Examples
    --------
    >>> import os, tempfile
    >>> fn = os.path.join(tempfile.mkdtemp(), "a.txt")
    >>> atomic_write(fn, "hello")
    >>> open(fn).read()
    'hello'
    """
    path = os.fspath(filename)
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=os.path.basename(path) + ".", suffix=".tmp", dir=folder)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data.encode() if isinstance(data, str) else data)
            f.flush()
            os.fsync(f.fileno())
        # mkstemp creates the file 0600: give it the permissions a plain open() would
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def to_jsonable(x):
    """``x`` with numpy scalars and arrays made plain and non-finite floats made ``None``.

    The one JSON convention of the package: NaN and +-inf are written as
    ``null`` (JSON has no NaN), everywhere.

    Examples
    --------
    >>> to_jsonable({"a": np.float64("nan"), "b": np.arange(2), "c": (1.5, float("inf"))})
    {'a': None, 'b': [0, 1], 'c': [1.5, None]}
    """
    if isinstance(x, dict):
        return {str(k): to_jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [to_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return to_jsonable(x.tolist())
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def dumps_json(data, indent=2, compact=False) -> str:
    """``data`` as JSON text (see :func:`to_jsonable`), strict: no NaN literals.

    Examples
    --------
    >>> dumps_json({"x": float("nan")}, indent=None)
    '{"x": null}'
    """
    if compact:  # one line, no spaces: journal lines and table cells
        return json.dumps(to_jsonable(data), separators=(",", ":"), allow_nan=False)
    return json.dumps(to_jsonable(data), indent=indent, allow_nan=False)


def check_writable(name: str, filename, suffixes=None) -> str:
    """Check up front that ``filename`` can be written (``ValueError`` naming ``name``)."""
    path = os.fspath(filename)
    if suffixes and not path.lower().endswith(tuple(suffixes)):
        raise ParameterError(f"{name} must end with {' or '.join(suffixes)}, got {path!r}")
    folder = os.path.dirname(os.path.abspath(path)) or "."
    if not os.path.isdir(folder):
        raise ParameterError(f"{name} must be in an existing folder, {folder!r} does not exist")
    if not os.access(folder, os.W_OK) or (os.path.exists(path) and not os.access(path, os.W_OK)):
        raise ParameterError(f"{name} must be a writable path, {path!r} is not")
    return path


def write_json(data: dict, filename) -> None:
    """Write ``data`` as indented JSON, atomically (temporary file + rename)."""
    atomic_write(filename, dumps_json(data) + "\n")


def write_result(result, filename) -> None:
    """Write a :class:`~skfem_sheet.solve.Result` as ``.vtu`` or ``.json``.

    The VTU holds the reference mesh (linear tetrahedra) with point data
    ``displacement`` (apply "Warp By Vector" in ParaView to see the deformed
    sheet) and ``pressure`` (paper convention), and cell data ``psi_over_mu``
    (in metres and pascals for a sheet made from SI quantities, as its field
    data ``coordinates_in_metres``, ``base_width_m`` say: :func:`in_units`);
    plus the fields of :func:`register_point_fields` (the mid-surface's
    ``midsurface_u``, ``midsurface_v``, ``midsurface_w``, ``E_ss``, ``E_st``,
    ``E_tt``, ``T_ss_over_Y``, ``T_tt_over_Y``, constant through the thickness).
    """
    path = check_writable("filename", filename, [".vtu", ".json"])
    if path.lower().endswith(".json"):
        write_json(result.summary(), path)
        return
    fields = whole_sheet_fields(result)
    extra = extra_point_fields(result.problem, result.w, fields[0])
    fields, units = in_units(result.sheet, fields)
    write_vtu(path, *fields, point_data=extra, field_data=units)


def in_units(sheet, fields):
    """The fields of :func:`whole_sheet_fields` in the units of ``sheet``, and
    the field data that states them.

    A sheet made from SI quantities (``sheet.si``) gets its reference
    vertices and displacements in metres and its pressure in pascals
    (``x a``, ``x rho g a``); the field data say so: ``coordinates_in_metres``
    1, ``base_width_m``, ``stress_scale_Pa`` (the mid-surface fields stay in
    units of a, strains and ``psi/mu`` are dimensionless).  A dimensionless
    sheet's fields are returned as they are, with ``coordinates_in_metres`` 0
    (lengths in base widths).

    Examples
    --------
    >>> import numpy as np
    >>> from skfem_sheet.params import Sheet
    >>> fields = (np.ones((3, 1)), None, np.ones((1, 3)), np.ones(1), np.ones(1))
    >>> out, data = in_units(Sheet.from_si(0.04, 0.052, 0.04, 1.2e-3, 0.016, 6e5, 1150), fields)
    >>> out[0].ravel().tolist(), data["coordinates_in_metres"], data["base_width_m"]
    ([0.04, 0.04, 0.04], 1.0, 0.04)
    """
    si = getattr(sheet, "si", None)
    if si is None:
        return fields, {"coordinates_in_metres": 0.0}
    p, t, U, pressure, psi = fields
    a = si.base_width
    return ((p * a, t, U * a, pressure * si.stress, psi),
            {"coordinates_in_metres": 1.0, "base_width_m": a, "stress_scale_Pa": si.stress})


def write_vtu(filename, p, t, displacement, pressure, psi, field_data=None,
              point_data=None) -> None:
    """Write the fields of :func:`whole_sheet_fields` as one VTU file (atomically).

    ``field_data`` (name -> number) is stored as VTU field data (one value
    each), e.g. the load of a step of a series; ``point_data`` (name ->
    array over the vertices) adds vertex fields.
    """
    # deferred: meshio is only needed to write VTU files
    import meshio

    out = meshio.Mesh(
        points=p.T, cells=[("tetra", t.T.astype(np.int64))],
        point_data={"displacement": displacement, "pressure": pressure, **(point_data or {})},
        cell_data={"psi_over_mu": [psi]})
    path = os.fspath(filename)
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=os.path.basename(path) + ".", suffix=".vtu", dir=folder)
    os.close(fd)
    try:
        meshio.write(tmp, out, file_format="vtu")
        with open(tmp, "rb") as f:
            data = f.read()
    finally:
        os.unlink(tmp)
    if field_data:
        # meshio's VTU writer drops field data (meshio 5.3): add the block by hand
        arrays = "".join(
            f'<DataArray type="Float64" Name={quoteattr(str(k))} NumberOfTuples="1" '
            f'format="ascii">{float(v)!r}</DataArray>\n' for k, v in field_data.items())
        data = data.replace(b"<Piece ", f"<FieldData>\n{arrays}</FieldData>\n<Piece ".encode(), 1)
    atomic_write(path, data)


def whole_sheet_fields(result):
    """Vertex fields of the whole sheet (a symmetric half solve is mirrored).

    Returns
    -------
    p : ndarray (3, n)
        Reference vertices.
    t : ndarray (4, m)
        Tetrahedra.
    displacement : ndarray (n, 3)
    pressure : ndarray (n,)
        Paper convention (``mu`` at rest).
    psi : ndarray (m,)
        psi/mu per tetrahedron.
    """
    return state_fields(result.problem, result.w)


def state_fields(problem, w):
    """:func:`whole_sheet_fields` of the state ``w`` of ``problem``.

    A problem stretched to another length (``problem.with_length``) gives
    the reference vertices of the stretched sheet (x scaled by
    ``problem.length / mesh.length``).
    """
    mesh = problem.sheet_mesh
    p, t, source, sign, element_source = mesh.mirrored()
    nv = mesh.n_vertices
    U, _ = problem.split(w)
    U = U[:nv][source]  # P2 vertex dofs come first (skfem numbering)
    U[:, 1] *= sign
    if problem.length != mesh.length:
        p = p * np.array([[problem.length / mesh.length], [1.0], [1.0]])
    pressure = problem.paper_pressure(w)[source]
    return p, t, U, pressure, problem.energy_density(w)[element_source]


# -- ParaView time series ------------------------------------------------------------
@dataclass(frozen=True)
class Frame:
    """One state of a series: its time, the problem it solves and the state."""

    time: float
    problem: object = field(repr=False)
    w: np.ndarray = field(repr=False)
    data: dict = field(default_factory=dict)


class Series:
    """States collected along a continuation, written as a ParaView series.

    Collects nothing until it is passed to a continuation:
    ``solve(..., series=s)`` (each accepted load step, via :meth:`on_step`) or
    the ``on_point`` callbacks of :mod:`skfem_sheet.bistability` (each point
    of a branch or S-curve, via :meth:`on_point`).  :meth:`write` then writes
    ``<directory>/<name>.pvd`` and one VTU file per state, with the fields of
    ``Result.write`` (whole sheet, mirrored).

    Time axis of the ``.pvd``: for a load path the load parameter
    ``t = kappa / (a/R) + g`` (curvature-first: 0..1 is the curvature ramp,
    1..2 gravity; gravity-first the reverse; a flat clamp has only the gravity
    ramp, 0..1); for a branch the continuation parameter (length or
    curvature) when it increases along the branch, otherwise the distance
    travelled in it, ``sum |dL|`` (a branch followed downwards, the
    S-curve).  The loads and the parameter are also stored in each VTU as
    field data (``kappa``, ``gravity``; ``parameter``).

    Memory: one copy of the state vector per frame (8 bytes per unknown),
    e.g. about 20 MB per step for a million unknowns.

    Examples
    --------
    >>> s = Series()
    >>> len(s), s.times().tolist()
    (0, [])
    """

    def __init__(self):
        self.frames = []

    def __len__(self):
        return len(self.frames)

    def add(self, time, problem, w, **data) -> None:
        """Record the state ``w`` of ``problem`` at ``time`` (copied)."""
        self.frames.append(Frame(float(time), problem, np.array(w, dtype=float, copy=True),
                                 dict(data)))

    def on_step(self, problem, w, kappa, g) -> None:
        """Hook of ``continuation.follow_path``: one accepted load step."""
        k_target = problem.sheet.curvature
        t = float(g) + (float(kappa) / k_target if k_target else 0.0)
        self.add(t, problem, w, kappa=float(kappa), gravity=float(g))

    def on_point(self, problem, w, value) -> None:
        """Hook of the continuations in :mod:`skfem_sheet.bistability`: one point."""
        self.add(value, problem, w, parameter=float(value))

    def times(self):
        """The series' times (see the class notes)."""
        v = np.array([f.time for f in self.frames], dtype=float)
        if len(v) > 1 and not np.all(np.diff(v) > 0):
            v = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(v)))])
        return v

    def write(self, directory, name, data=None) -> str:
        """Write ``directory/name.pvd`` and ``directory/name/name_NNNN.vtu``.

        ``data`` (optional) is a list of extra field data, one dict per
        frame.  Returns the path of the ``.pvd``.
        """
        return write_series(directory, name, self.frames, times=self.times(), data=data)


def write_series(directory, name, frames, times=None, data=None) -> str:
    """Write a ParaView time series: ``directory/name.pvd`` and one VTU per frame.

    Parameters
    ----------
    directory : path
        Created if missing (its parent must exist).
    name : str
        File name stem: a letter, digit, ``_``, ``-`` or ``.``, no separators.
    frames : sequence of Frame
    times : sequence of float, optional
        Strictly increasing times (default: the frames' own times).
    data : sequence of dict, optional
        Extra field data per frame.

    Returns
    -------
    str
        The ``.pvd`` path.  The VTU files are in ``directory/name/``,
        referred to by relative paths.
    """
    directory = os.fspath(directory)
    name = str(name)
    if not name or not all(c.isalnum() or c in "_-." for c in name) or name.startswith("."):
        raise ParameterError(f"series name must be letters, digits, '_', '-' or '.', "
                             f"got {name!r}")
    frames = list(frames)
    times = np.array([f.time for f in frames] if times is None else times, dtype=float)
    if len(times) != len(frames):
        raise ParameterError(f"times must have one value per frame ({len(frames)}), "
                             f"got {len(times)}")
    if not np.all(np.isfinite(times)) or (len(times) > 1 and not np.all(np.diff(times) > 0)):
        raise ParameterError("times must be finite and strictly increasing")
    if data is not None and len(data) != len(frames):
        raise ParameterError(f"data must have one dict per frame ({len(frames)}), "
                             f"got {len(data)}")
    check_directory("series directory", directory)
    os.makedirs(os.path.join(directory, name), exist_ok=True)
    entries = []
    for i, (frame, t) in enumerate(zip(frames, times)):
        rel = f"{name}/{name}_{i:04d}.vtu"
        extra = {**frame.data, **(data[i] if data is not None else {})}
        fields, units = in_units(frame.problem.sheet, state_fields(frame.problem, frame.w))
        write_vtu(os.path.join(directory, rel), *fields,
                  field_data={"time": float(t), **extra, **units})
        entries.append(f'    <DataSet timestep="{float(t)!r}" group="" part="0" '
                       f'file={quoteattr(rel)}/>')
    pvd = ("<?xml version=\"1.0\"?>\n"
           '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
           "  <Collection>\n" + "".join(e + "\n" for e in entries)
           + "  </Collection>\n</VTKFile>\n")
    path = os.path.join(directory, name + ".pvd")
    atomic_write(path, pvd)
    return path


def read_pvd(filename):
    """The ``(time, absolute VTU path)`` pairs of a ``.pvd`` collection, in file order."""
    path = os.fspath(filename)
    root = ET.parse(path).getroot()
    folder = os.path.dirname(os.path.abspath(path))
    return [(float(d.get("timestep")), os.path.join(folder, d.get("file")))
            for d in root.iter("DataSet")]


def check_directory(name: str, directory) -> str:
    """Check up front that ``directory`` can be created or written into
    (``ParameterError`` naming ``name``)."""
    path = os.fspath(directory)
    if os.path.exists(path) and not os.path.isdir(path):
        raise ParameterError(f"{name} must be a directory, {path!r} is a file")
    parent = path if os.path.isdir(path) else (os.path.dirname(os.path.abspath(path)) or ".")
    if not os.path.isdir(parent):
        raise ParameterError(f"{name} must be in an existing folder, {parent!r} does not exist")
    if not os.access(parent, os.W_OK):
        raise ParameterError(f"{name} must be writable, {parent!r} is not")
    return path
