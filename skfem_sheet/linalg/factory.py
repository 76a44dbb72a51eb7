"""The back-end by name: which are installed (:func:`available_solvers`) and one
made (:func:`make_linear_solver`, ``"auto"``: pardiso when importable, else
superlu).
"""
from __future__ import annotations

from ..params import ParameterError
from .amg import PyAMGSolver
from .base import SOLVERS
from .mkl import locate_mkl
from .pardiso import PardisoSolver
from .superlu import SuperLUSolver


def _have_pardiso() -> bool:
    locate_mkl()
    try:
        import pypardiso  # noqa: F401  (optional dependency: only probed)
    except (ImportError, OSError):
        return False
    return True


def _have_pyamg() -> bool:
    try:
        import pyamg  # noqa: F401  (deferred, probed only: see PyAMGSolver._setup)
    except ImportError:
        return False
    return True


def available_solvers():
    """Names of the back-ends usable on this machine (besides ``"auto"``).

    Examples
    --------
    >>> "superlu" in available_solvers()
    True
    """
    have = {"pardiso": _have_pardiso, "pyamg": _have_pyamg}
    return [s for s in SOLVERS[1:] if have.get(s, lambda: True)()]


def make_linear_solver(name: str = "auto", **options):
    """Create a linear-solver back-end by name (see the module docstring).

    Parameters
    ----------
    name : {"auto", "pardiso", "superlu", "pyamg"}
    **options
        Passed to the back-end's constructor (e.g. ``rtol`` of
        :class:`PyAMGSolver`, ``reproducible`` or ``pivot_perturbation`` of
        :class:`PardisoSolver`; every back-end takes ``reproducible``, the
        serial ones are reproducible whatever it says).

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> s = make_linear_solver("superlu")
    >>> s.factorize(sp.csr_matrix([[2.0, 1.0], [1.0, -1.0]]))
    >>> s.solve([3.0, 0.0]), s.inertia()
    (array([1., 1.]), (1, 1, 0))
    """
    if name not in SOLVERS:
        raise ParameterError(f"solver must be one of {', '.join(SOLVERS)}, got {name!r}")
    if name == "auto":
        name = "pardiso" if _have_pardiso() else "superlu"
    if name == "pardiso":
        if not _have_pardiso():
            raise ParameterError("solver 'pardiso' needs pypardiso: "
                                 "pip install 'skfem_sheet[fast]'")
        return PardisoSolver(**options)
    if name == "pyamg":
        if not _have_pyamg():
            raise ParameterError("solver 'pyamg' needs pyamg: pip install pyamg")
        return PyAMGSolver(**options)
    return SuperLUSolver(**options)
