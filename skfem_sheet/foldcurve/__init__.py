"""Fold curves of the 3D sheet in (L, b) at a fixed clamp curvature (or in (L, a/R)), and the cusp.

The pop-up and standout lengths ``L0*(b)`` and ``L1*(b)`` (paper, Figs. 6
and 7) are the two halves of one *fold curve* in the plane ``(L, b)``: from
``L1*`` at ``b = 1`` down to the *cusp*, where the two folds meet and the
bistable range closes, and back up as ``L0*(b)``.  :func:`trace_fold_curve`
locates the fold at ``b = 1`` by natural continuation in L and continues it
in ``(L, b)`` with the minimally augmented system
(:mod:`skfem_sheet.engine`); the cusp is where the quadratic fold
coefficient changes sign, and each point is a ``"standout"`` or ``"popup"``
fold by the side on which its branch exists.
:func:`trace_curvature_fold_curve` does the same in ``(L, a/R)``.  The sheet
is :class:`~skfem_sheet.sheet_shape.SheetFoldProblem`: one mesh mapped to
each ``(L, b)`` and remeshed by the one remesh rule of
:mod:`skfem_sheet.sheet_shape`.

Coarse to fine (``coarse_hmax``): the curve is traced on a coarse mesh and a
few of its points (the ends, points spaced evenly, the cusp's neighbours)
are carried level by level onto finer meshes and corrected there with the
minimally augmented system (:mod:`.refine`); the cusp is then located on the
fine mesh (:mod:`.cusp`), and an end that does not converge there is traced
on that mesh instead (:func:`~skfem_sheet.foldcurve.refine.continue_to_end`).

Modules: :mod:`.options` (what a trace is asked for, its tolerances),
:mod:`.result` (:class:`FoldCurve`), :mod:`.trace` (the direct trace),
:mod:`.refine` (coarse to fine), :mod:`.cusp`, :mod:`.series` (ParaView).
"""
from __future__ import annotations

import numpy as np

from ..params import check_range
from ..sheet_shape import (
    MIN_SQUEEZE,
    REMESH_SQUEEZE,
    REMESH_STRETCH,
    TOLERANCES,
    SheetFoldProblem,
)
from .cusp import CUSP_ITERATIONS, CUSP_STEP, CUSP_TOL
from .options import (
    FINE_TOLERANCES,
    MAX_REMESHES,
    PREDICTOR,
    REFILL_DS,
    TARGET_CORRECTION,
    FoldCurveOptions,
    default_start_length,
)
from .refine import KeptPoint, RefinedPoint, run
from .result import FoldCurve

__all__ = ["CUSP_ITERATIONS", "CUSP_STEP", "CUSP_TOL", "FINE_TOLERANCES", "MAX_REMESHES",
           "MIN_SQUEEZE", "PREDICTOR", "REFILL_DS", "REMESH_SQUEEZE", "REMESH_STRETCH",
           "TARGET_CORRECTION", "TOLERANCES", "FoldCurve", "FoldCurveOptions", "KeptPoint",
           "RefinedPoint", "SheetFoldProblem", "default_start_length",
           "trace_curvature_fold_curve", "trace_fold_curve"]


def trace_fold_curve(curvature: float, hmax: float = 0.1, *, start_length=None,
                     length_range=(0.6, 2.4), min_tip_width: float = 0.2,
                     thickness: float = 0.03, modulus: float = 735.0, layers=None,
                     solver: str = "auto", ds: float = 0.05, ds_max: float = 0.4,
                     check_inertia=10, mesh_length=None, max_points: int = 400,
                     progress: bool = False, coarse_hmax=None,
                     fine_points: int = 12, series=None) -> FoldCurve:
    """Trace the fold curve in (L, b) at clamp curvature ``curvature``.

    1. Solve the sheet at ``(start_length, b = 1)`` curvature-first, and follow
       the curvature-dominated branch in L (natural continuation) until its
       fold, located with the minimally augmented system: ``L1*(1)``.
    2. Continue that fold in ``(L, b)`` with decreasing ``b``
       (:func:`skfem_sheet.engine.fold_curve`) until the curve returns to
       ``b = 1`` (``L0*(1)``, the last point, put on ``b = 1``), locating the
       cusp on the way.

    Parameters
    ----------
    curvature : float
        a/R, in (0, 2 pi).
    hmax : float
        Mesh size (one mesh for the whole curve).
    start_length : float, optional
        Length of the first solve, below ``L0*`` (default
        :func:`default_start_length`).
    length_range : (float, float)
        The curve stops if L leaves this range (and a curvature whose
        curvature-dominated branch reaches its end without a fold is reported
        as not bistable).
    min_tip_width : float
        The curve stops below this tip width.
    ds, ds_max : float
        First and largest arclength step.
    check_inertia : bool or int
        Confirm on every (True) or every n-th point that exactly one
        eigenvalue crosses zero (two extra factorisations per checked point;
        at the fold itself the count of the near-zero pivot is not reliable
        with pivot perturbation, hence the check beside it).
    max_points : int
        Largest number of points of the curve.
    mesh_length : float, optional
        Length of the first mesh (default: ``1.08 start_length``); the trace
        remeshes beyond :data:`~skfem_sheet.sheet_shape.REMESH_STRETCH` /
        :data:`~skfem_sheet.sheet_shape.REMESH_SQUEEZE`.
    progress : bool
        tqdm bar on stderr.
    coarse_hmax : float or sequence of float, optional
        Coarse to fine: trace the curve at this (coarser) mesh size first
        (several: at the coarsest, then refined level by level),
        then correct ``fine_points`` of its points (and both ends, and the
        points around the cusp) on meshes of size ``hmax``, each from the
        coarse fold carried over, with the minimally augmented system: a few
        factorisations at ``hmax`` per point, no load path or continuation
        there.  The cusp is then located on the fine mesh where the
        refined points' fold coefficient changes sign (a few more fold
        points there).
    fine_points : int
        Points of the coarse curve refined (spaced evenly in the plane of
        the parameters), besides the ends and the cusp's neighbours.
    series : skfem_sheet.io.Series, optional
        Collects the state of every point of the curve (time: its index
        along the curve); write it with ``series.write(directory, name)``.

    Returns
    -------
    FoldCurve

    Examples
    --------
    >>> c = trace_fold_curve(2.5, hmax=0.1)  # doctest: +SKIP
    >>> c.standout_length, c.popup_length, c.cusp  # doctest: +SKIP
    """
    curvature = check_range("curvature", curvature, 0, 2 * np.pi, lo_open=True, hi_open=True)
    min_tip_width = check_range("min_tip_width", min_tip_width, 0, 1, lo_open=True, hi_open=True)
    options = FoldCurveOptions(hmax, start_length, length_range, thickness, modulus, layers,
                               solver, ds, ds_max, check_inertia, mesh_length, max_points,
                               progress, coarse_hmax, fine_points)
    return run(curvature, 1.0, 1, (min_tip_width, 1.0), options, series)


def trace_curvature_fold_curve(tip_width: float = 1.0, curvature: float = 2.5,
                               hmax: float = 0.1, *, min_curvature: float = 0.3,
                               start_length=None, length_range=(0.6, 2.4),
                               thickness: float = 0.03, modulus: float = 735.0, layers=None,
                               solver: str = "auto", ds: float = 0.05, ds_max: float = 0.4,
                               check_inertia=10, mesh_length=None, max_points: int = 400,
                               progress: bool = False, coarse_hmax=None,
                               fine_points: int = 12, series=None) -> FoldCurve:
    """Trace the fold curve in (L, a/R) at tip width ``tip_width``.

    The same as :func:`trace_fold_curve` with the clamp curvature as the
    second parameter: from the standout fold at ``curvature`` the fold is
    continued to lower curvatures, through the cusp where bistability starts,
    and back to ``curvature`` as the pop-up fold.  The points carry
    ``curvature`` instead of ``tip_width``; the cusp is ``{"curvature",
    "length"}``.  Parameters as for :func:`trace_fold_curve`;
    ``min_curvature`` bounds the curve below.

    Examples
    --------
    >>> c = trace_curvature_fold_curve(1.0, 2.5, hmax=0.1)  # doctest: +SKIP
    >>> c.cusp["curvature"]  # doctest: +SKIP
    """
    tip_width = check_range("tip_width", tip_width, 0, 1, lo_open=True)
    curvature = check_range("curvature", curvature, 0, 2 * np.pi, lo_open=True, hi_open=True)
    min_curvature = check_range("min_curvature", min_curvature, 0, curvature, lo_open=True,
                                hi_open=True)
    options = FoldCurveOptions(hmax, start_length, length_range, thickness, modulus, layers,
                               solver, ds, ds_max, check_inertia, mesh_length, max_points,
                               progress, coarse_hmax, fine_points)
    return run(curvature, tip_width, 2, (min_curvature, curvature), options, series)
