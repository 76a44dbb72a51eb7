"""Analyses of a solved state: stability (inertia), observables, transfer between meshes.

Layer 7: below the continuation engine, load paths and ``solve``; uses the
problem, the linear solvers and Newton only.
"""

# the mid-surface fields go into every result VTU (skfem_sheet.io.register_point_fields)
from . import midsurface  # noqa: E402,F401
