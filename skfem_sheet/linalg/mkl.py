"""Where Intel MKL is (for PARDISO): located from the mkl wheel's file list
without a directory scan (:func:`locate_mkl`), remembered for later solvers and
worker processes (:func:`remember_mkl`), and its thread count
(:func:`mkl_threads`).
"""
from __future__ import annotations

import importlib.metadata as md
import os


def locate_mkl() -> None:
    """Tell pypardiso where MKL's ``mkl_rt`` is before it looks for itself.

    Importing pypardiso creates a solver, which (unless ``PYPARDISO_MKL_RT``
    is set) globs ``sys.prefix`` recursively for ``mkl_rt``: 1-2 s per
    process, a visible share of a coarse solve and of every sweep worker.
    The ``mkl`` wheel's file list (``importlib.metadata``) names the library
    in milliseconds.  Nothing is set if it is not found there (pypardiso then
    searches as usual) or if the user set the variable.
    """
    if "PYPARDISO_MKL_RT" in os.environ:
        return
    try:
        files = md.files("mkl") or []
    except md.PackageNotFoundError:
        return
    for f in sorted((f for f in files if f.name.startswith("libmkl_rt.so")
                     or f.name == "mkl_rt.dll" or f.name.startswith("libmkl_rt.")),
                    key=lambda f: len(str(f))):
        path = os.path.realpath(f.locate())
        if os.path.isfile(path):
            os.environ["PYPARDISO_MKL_RT"] = path
            return


def remember_mkl(ps):
    """Remember where pypardiso found MKL.

    Without ``PYPARDISO_MKL_RT`` (pypardiso's own setting) every
    ``PyPardisoSolver()`` scans ``sys.prefix`` recursively for ``mkl_rt``,
    about 1 s per solve, which dominates coarse solves in a sweep.  Setting it
    once makes later solvers (and sweep worker processes, which inherit the
    environment) load the library directly.
    """
    name = getattr(ps.libmkl, "_name", None)
    if name and "PYPARDISO_MKL_RT" not in os.environ:
        os.environ["PYPARDISO_MKL_RT"] = name


def mkl_threads(ps):
    """MKL's thread count in this process (``MKL_Get_Max_Threads``), at least 1.

    The value only sets how PARDISO's reproducible mode partitions the work:
    the results are the same bits for any value and any actual thread count
    (checked with 1, 2 and 3 threads on the sheet tangent).
    """
    try:
        return max(1, int(ps.libmkl.MKL_Get_Max_Threads()))
    except (AttributeError, OSError):  # an MKL without the service function
        return max(1, os.cpu_count() or 1)
