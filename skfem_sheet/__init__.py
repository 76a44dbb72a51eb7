"""skfem_sheet: curvature-induced rigidity of a clamped, sagging elastic sheet.

A 3D finite-element solver (incompressible neo-Hookean, Taylor-Hood
tetrahedra, scikit-fem) and the reduced-order models of Mao, Chandler, Han &
Spagnolie, "Geometric dependence of curvature-induced rigidity".

The names below are imported on first use, so that ``import skfem_sheet``
(and ``python -m skfem_sheet --version``) does not load the numerics.

Examples
--------
>>> from skfem_sheet import Sheet, solve
>>> r = solve(Sheet(length=0.5, curvature=1.0), hmax=0.1)
>>> r.converged
True
"""
import sys
import types
from importlib import import_module

from .version import __version__

#: public name -> the module that defines it (imported on first access)
_LAZY = {
    "Sheet": "skfem_sheet.params",
    "Result": "skfem_sheet.result",
    "SolveError": "skfem_sheet.result",
    "CoarseStart": "skfem_sheet.starts",
    "solve_both": "skfem_sheet.states",
    "PathStart": "skfem_sheet.starts",
    "NewtonOptions": "skfem_sheet.newton",
    "StepOptions": "skfem_sheet.continuation",
    "calibrate": "skfem_sheet.calibration",
    "switching": "skfem_sheet.switch",
}

__all__ = ["Sheet", "solve", "Result", "SolveError", "NewtonOptions", "StepOptions",
           "CoarseStart", "PathStart", "calibrate", "solve_both", "switching", "__version__"]


def __getattr__(name):
    if name in _LAZY:
        value = getattr(import_module(_LAZY[name]), name)
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
