"""``skfem-sheet demo``: ``solve`` with the defaults of a demonstration.

The paper's bistable rectangle (L/a = 1.3, a/R = 2.5) on its aloft branch,
at hmax 0.04, writing ``demo.png`` and ``demo.vtu``; the same code path as
``solve`` (:func:`skfem_sheet.cli.solve.run`).
"""
from __future__ import annotations

from .solve import add_sheet_args, add_solve_args, run

__all__ = ["register"]


def register(subparsers) -> None:
    """Add the ``demo`` command."""
    p = subparsers.add_parser("demo", help="solve a default sheet, print d, write PNG and VTU")
    add_sheet_args(p, length=1.3)
    p.set_defaults(curvature=2.5)
    add_solve_args(p, hmax=0.04)
    p.set_defaults(run=run, png="demo.png", vtu="demo.vtu", json=None)
