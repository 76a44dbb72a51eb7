"""skfem_sheet: curvature-induced rigidity of a clamped, sagging elastic sheet.

A 3D finite-element solver (incompressible neo-Hookean, Taylor-Hood
tetrahedra, scikit-fem) and the reduced-order models of Mao, Chandler, Han &
Spagnolie, "Geometric dependence of curvature-induced rigidity".

Examples
--------
>>> from skfem_sheet import Sheet, solve
>>> r = solve(Sheet(length=0.5, curvature=1.0), hmax=0.1)
>>> r.converged
True
"""
from .continuation import StepOptions
from .newton import NewtonOptions
from .params import Sheet
from .solve import Result, SolveError, solve
from .version import __version__

__all__ = ["Sheet", "solve", "Result", "SolveError", "NewtonOptions", "StepOptions",
           "__version__"]
