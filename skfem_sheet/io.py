"""Writing results: VTU (ParaView) through meshio, JSON summaries."""
from __future__ import annotations

import json
import os

import numpy as np

from .params import ParameterError

__all__ = ["write_result", "write_json", "check_writable", "whole_sheet_fields"]


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
    path = os.fspath(filename)
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        json.dump(data, f, indent=2, default=_jsonable)
        f.write("\n")
    os.replace(tmp, path)


def _jsonable(x):
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    raise TypeError(f"not JSON serialisable: {type(x).__name__}")


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
