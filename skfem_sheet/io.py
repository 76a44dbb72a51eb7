"""Writing results: VTU (ParaView) through meshio, JSON summaries."""
from __future__ import annotations

import json
import math
import os
import tempfile

import numpy as np

from .params import ParameterError

__all__ = ["write_result", "write_json", "check_writable", "whole_sheet_fields",
           "atomic_write", "to_jsonable", "dumps_json"]


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


def dumps_json(data, indent=2) -> str:
    """``data`` as JSON text (see :func:`to_jsonable`), strict: no NaN literals.

    Examples
    --------
    >>> dumps_json({"x": float("nan")}, indent=None)
    '{"x": null}'
    """
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
    sheet) and ``pressure`` (paper convention), and cell data ``psi_over_mu``.
    """
    path = check_writable("filename", filename, [".vtu", ".json"])
    if path.lower().endswith(".json"):
        write_json(result.summary(), path)
        return
    import meshio

    p, t, U, pressure, psi = whole_sheet_fields(result)
    out = meshio.Mesh(
        points=p.T, cells=[("tetra", t.T.astype(np.int64))],
        point_data={"displacement": U, "pressure": pressure},
        cell_data={"psi_over_mu": [psi]})
    meshio.write(path, out, file_format="vtu")


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
    mesh = result.problem.sheet_mesh
    p, t, source, sign, element_source = mesh.mirrored()
    nv = mesh.n_vertices
    U = result.displacement[:nv][source]  # P2 vertex dofs come first (skfem numbering)
    U[:, 1] *= sign
    return p, t, U, result.pressure[source], result.energy_density[element_source]
