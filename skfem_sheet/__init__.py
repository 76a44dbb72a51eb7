"""skfem_sheet: curvature-induced rigidity of a clamped, sagging elastic sheet.

A 3D finite-element solver (incompressible neo-Hookean, Taylor-Hood
tetrahedra, scikit-fem) and the reduced-order models of Mao, Chandler, Han &
Spagnolie, "Geometric dependence of curvature-induced rigidity".

The names below are imported on first use, so that ``import skfem_sheet``
(and ``python -m skfem_sheet --version``) does not load the numerics.

Every analysis takes a :class:`Sheet` (its planform, clamp curvature,
thickness and modulus; :meth:`Sheet.from_si` for one in SI units, whose
answers are then reported in SI units too) and a mesh size (default
``DEFAULT_HMAX`` = 0.03, the paper's; ``QUICK_HMAX`` = 0.1 for a quick look).

Examples
--------
>>> from skfem_sheet import Sheet, solve
>>> r = solve(Sheet(length=0.5, curvature=1.0), hmax=0.1)
>>> r.converged, r.branch
(True, 'curvature-dominated')
"""
import sys
import types
from importlib import import_module

from .version import __version__

#: public name -> the module that defines it (imported on first access), or
#: ``(module, name there)``.  One name per job: ``solve`` (one sheet, one load
#: path), ``solve_both`` (both paths: is it bistable?), ``fold_lengths`` (L0*,
#: L1* of its planform at its curvature), ``s_curve`` (d(L) through both folds),
#: ``fold_curve`` (the fold curve and its cusp), ``sweep`` (a family of
#: sheets into a resumable table), ``figure`` (a figure of the paper).
_LAZY = {
    "Sheet": "skfem_sheet.params",
    "Planform": "skfem_sheet.params",
    "Result": "skfem_sheet.result",
    "SolveError": "skfem_sheet.result",
    "CoarseStart": "skfem_sheet.starts",
    "solve_both": "skfem_sheet.states",
    "States": "skfem_sheet.states",
    "fold_lengths": "skfem_sheet.bistability",
    "FoldLengths": "skfem_sheet.bistability",
    "s_curve": "skfem_sheet.bistability",
    "fold_curve": "skfem_sheet.bistability",
    "sweep": "skfem_sheet.studies.sweep",
    "figure": ("skfem_sheet.figures.registry", "make_figure"),
    "PathStart": "skfem_sheet.starts",
    "NewtonOptions": "skfem_sheet.newton",
    "StepOptions": "skfem_sheet.continuation",
    "calibrate": "skfem_sheet.calibration",
    "DEFAULT_HMAX": "skfem_sheet.params",
    "QUICK_HMAX": "skfem_sheet.params",
    "switching": "skfem_sheet.switch",
}

__all__ = ["Sheet", "Planform", "solve", "solve_both", "fold_lengths", "s_curve", "fold_curve",
           "sweep", "figure", "switching", "Result", "States", "FoldLengths", "SolveError",
           "NewtonOptions", "StepOptions", "CoarseStart", "PathStart", "calibrate",
           "DEFAULT_HMAX", "QUICK_HMAX", "__version__"]


def __getattr__(name):
    if name in _LAZY:
        module, attr = _LAZY[name] if isinstance(_LAZY[name], tuple) else (_LAZY[name], name)
        value = getattr(import_module(module), attr)
        globals()[name] = value     # later look-ups skip this function
        return value
    raise AttributeError(f"module 'skfem_sheet' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_LAZY) | {"solve"})


class _Package(types.ModuleType):
    """The package's module type: ``skfem_sheet.solve`` is the function ``solve``.

    Importing the submodule ``skfem_sheet.solve`` binds it as an attribute of the
    package; this property keeps the name for the function (as ``from .solve import
    solve`` in an eager ``__init__`` did), whichever is imported first.
    """

    @property
    def solve(self):
        return import_module("skfem_sheet.solve").solve

    @solve.setter
    def solve(self, module):    # the import system binding the submodule: keep the function
        pass


sys.modules[__name__].__class__ = _Package
