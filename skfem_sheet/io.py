"""Writing results: VTU (ParaView) through meshio, JSON summaries."""
from __future__ import annotations

import json
import os

import numpy as np

from .params import ParameterError

__all__ = ["write_result", "write_json", "check_writable"]


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

    problem = result.problem
    mesh = problem.sheet_mesh.mesh
    nv = mesh.p.shape[1]
    U = result.displacement[:nv]  # P2 vertex dofs come first (skfem numbering)
    cells = [("tetra", mesh.t.T.astype(np.int64))]
    out = meshio.Mesh(
        points=mesh.p.T, cells=cells,
        point_data={"displacement": U, "pressure": result.pressure},
        cell_data={"psi_over_mu": [result.energy_density]})
    meshio.write(path, out, file_format="vtu")
