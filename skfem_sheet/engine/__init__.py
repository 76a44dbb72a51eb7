"""The continuation engine: one problem protocol and the drivers that use it.

Layer 8: natural continuation with fold detection, pseudo-arclength, and fold-curve
(two-parameter) continuation; knows nothing of the sheet.

Modules
-------
:mod:`.protocol`
    the problem protocol (:class:`Problem`: residual, jacobian, factorize with
    ``solve``/``inertia``, dresidual, dual/inner, norms) and :class:`Stats`;
:mod:`.corrector`
    the one Newton corrector (:func:`correct`, :func:`newton`) and bordered
    solves (:class:`Bordered`);
:mod:`.fold`
    the minimally augmented test function and fold location (:func:`locate_fold`);
:mod:`.branch`
    natural (:func:`natural`) and pseudo-arclength (:func:`arclength`) continuation,
    and sweeps through prescribed values (:func:`sweep`);
:mod:`.curves`
    fold curves in two parameters and cusps on them (:func:`fold_curve`).
"""
from .branch import Branch, BranchPoint, arclength, natural, sweep
from .corrector import Bordered, ChordTest, NewtonResult, Tolerances, correct, newton
from .curves import Cusp, FoldCurve, FoldCurvePoint, fold_curve
from .fold import FoldPoint, fold_on_section, fold_test, locate_fold
from .loadpath import ramp
from .protocol import (
                       DenseFactorization,
                       EngineFailure,
                       FunctionProblem,
                       Problem,
                       SparseLUFactorization,
                       Stats,
)
from .steps import StepRule

__all__ = [
                       "Bordered",
                       "ChordTest",
                       "Branch",
                       "BranchPoint",
                       "Cusp",
                       "DenseFactorization",
                       "EngineFailure",
                       "FoldCurve",
                       "FoldCurvePoint",
                       "FoldPoint",
                       "FunctionProblem",
                       "NewtonResult",
                       "Problem",
                       "SparseLUFactorization",
                       "Stats",
                       "StepRule",
                       "Tolerances",
                       "arclength",
                       "correct",
                       "fold_curve",
                       "fold_test",
                       "fold_on_section",
                       "locate_fold",
                       "natural",
                       "newton",
                       "ramp",
                       "sweep",
]
