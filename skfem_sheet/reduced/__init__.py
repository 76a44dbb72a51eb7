"""Reduced-order models of a curved, clamped sheet sagging under its own weight.

Paper main text "Reduced-order modeling" and supplement
"Reduced-order theory: small plate rotations" / "large plate rotations".
Every model takes a :class:`skfem_sheet.params.Sheet` (dimensionless, base
width a = 1, rho g = 1) and reports deflections positive downward.

- :func:`persistence_length` -- gravity-free persistence length (eqs. code2-code3).
- :func:`cantilever_deflection` -- Euler--Bernoulli estimate beyond L_p.
- :func:`elastica` -- heavy elastica with varying width (eq. phODE2).
- :func:`ribbon`, :func:`ribbon_continuation` -- ribbon model with transverse
  curvature, traced in L in both directions (:func:`ribbon_energy_terms` splits
  its energy into stretching, bending, Poisson, twisting and gravity terms).
- :func:`ribbon_map` -- the Fig. 6 deflection map (+ :func:`write_map_csv`,
  :func:`plot_map`).

Examples
--------
>>> from skfem_sheet.params import Sheet
>>> from skfem_sheet.reduced import elastica, persistence_length
>>> round(elastica(Sheet(length=1.0)).deflection, 3)
0.768
>>> round(persistence_length(Sheet(length=5.0, curvature=2.5)).persistence_length, 4)
1.0911
"""
from skfem_sheet.reduced.cantilever import (
                                            CantileverResult,
                                            cantilever_coefficient,
                                            cantilever_deflection,
)
from skfem_sheet.reduced.elastica import ElasticaResult, elastica, elastica_linear_deflection
from skfem_sheet.reduced.maps import jump_curve, plot_map, ribbon_map, write_map_csv
from skfem_sheet.reduced.persistence import (
                                            PersistenceResult,
                                            persistence_length,
                                            persistence_length_asymptotic,
)
from skfem_sheet.reduced.ribbon import (
                                            ContinuationResult,
                                            RibbonResult,
                                            detect_jumps,
                                            ribbon,
                                            ribbon_continuation,
                                            ribbon_energy_terms,
)

__all__ = [
    "CantileverResult", "ContinuationResult", "ElasticaResult", "PersistenceResult",
    "RibbonResult", "cantilever_coefficient", "cantilever_deflection", "detect_jumps",
    "elastica", "elastica_linear_deflection", "jump_curve", "persistence_length",
    "persistence_length_asymptotic", "plot_map", "ribbon", "ribbon_continuation",
    "ribbon_energy_terms", "ribbon_map", "write_map_csv",
]
