"""Bistability: continuation in the sheet length, fold lengths located, the S-curve.

In the bistable range ``L0* < L < L1*`` a sheet has two stable equilibria
(paper, Figs. 2, 4, 6 and 7): the curvature-dominated one, which exists up to
the *standout length* ``L1*``, and the gravity-dominated one, down to the
*pop-up length* ``L0*``; with the unstable branch between them they form an
S-shaped curve ``d(L)`` whose folds are ``L0*`` and ``L1*``.  One idea a
module: :mod:`~skfem_sheet.bistability.branch` (:class:`BranchPoint`,
:class:`Branch`), :mod:`~skfem_sheet.bistability.follow` (one branch
continued in L or a/R: :func:`follow_length`, :func:`follow_curvature`),
:mod:`~skfem_sheet.bistability.folds` (:class:`Fold`, :class:`FoldLengths`,
:class:`FoldPosition`, :func:`fold_position`),
:mod:`~skfem_sheet.bistability.lengths` (:func:`fold_lengths`, each fold
located once more on a mesh made at it, :func:`locate_on_mesh`),
:mod:`~skfem_sheet.bistability.curve` (:func:`fold_curve`) and
:mod:`~skfem_sheet.bistability.scurve` (:func:`s_curve`, through both folds).
"""
from __future__ import annotations

import warnings

from ..analyses.stability import stability
from ..analyses.transfer import transfer
from ..params import Sheet as Sheet  # public here, as in the module before
from .branch import Branch, BranchPoint
from .curve import FOLD_CURVE_LEVELS, FOLD_CURVE_POINTS, fold_curve
from .folds import Fold, FoldLengths, FoldPosition, fold_position
from .follow import FOLD_TOL, follow_curvature, follow_length
from .follow import MIN_STEP as MIN_STEP
from .lengths import FOLD_GAP as FOLD_GAP
from .lengths import (
    TRACE_HMAX,
    fold_lengths,
    fold_lengths_of,
    fold_range,
    locate_on_mesh,
    trace_mesh,
)
from .scurve import SCurve, s_curve

__all__ = ["BranchPoint", "Branch", "Fold", "FoldLengths", "FoldPosition",
           "SCurve", "FOLD_TOL", "TRACE_HMAX", "FOLD_CURVE_LEVELS", "FOLD_CURVE_POINTS",
           "fold_curve", "stability", "transfer", "follow_length",
           "follow_curvature", "fold_lengths", "fold_lengths_of", "fold_position", "fold_range",
           "locate_on_mesh", "s_curve", "trace_mesh"]


def __getattr__(name):
    """``Bistability``: the old name of :class:`FoldLengths` (before the folds
    were located and the function took a Sheet), with a DeprecationWarning;
    kept one release."""
    if name == "Bistability":
        warnings.warn("skfem_sheet.bistability.Bistability is deprecated: it is FoldLengths",
                      DeprecationWarning, stacklevel=2)
        return FoldLengths
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
