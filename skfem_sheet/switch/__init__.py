"""How hard is it to switch? The tip force that snaps a bistable sheet, and the barrier.

A bistable sheet has, at zero load, two stable equilibria (aloft and
drooped) and between them the unstable **saddle** of the energy that a
switch passes over.  A vertical tip force ``F``
(:meth:`~skfem_sheet.problem.SheetProblem.with_tip_force`: a dead load over
the tip face, positive upward, units of ``rho g a^3``) connects the three on
an S-shaped curve of equilibria: the aloft branch ends at the fold
``F_down < 0`` (the **switching force down**), the unstable branch passes
``F = 0`` at the saddle, and the drooped branch ends at ``F_up > 0``.
:func:`force_curve` traces it by pseudo-arclength continuation in ``F``
(:class:`~skfem_sheet.sheet_engine.SheetForceProblem`) with the inertia of
every point, and locates each fold on the branch
(:func:`~skfem_sheet.engine.fold.fold_on_branch`, else
:func:`~skfem_sheet.engine.locate_fold`).

The **barriers** ``barrier_down = Pi(saddle) - Pi(aloft)`` and
``barrier_up = Pi(saddle) - Pi(drooped)`` (units of ``rho g a^4``) are the
work a quasi-static switch takes.  The tests check: the work identity
``dPi = F dw_tip`` along the curve (integrated in ``w_tip`` with the tip
stiffness ``k = dF/dw_tip``, Hermite cubics); the saddle equal to the S-curve
in L's middle state (:func:`skfem_sheet.bistability.s_curve`); and the
saddle-node scaling near ``L1*`` (and ``L0*``): ``F_down ~ L1* - L``,
``barrier_down ~ (L1* - L)^{3/2}`` (normal form ``a x^3/3 - mu x - F x``).

One idea a module: :mod:`~skfem_sheet.switch.curve` (:class:`CurvePoint`,
:class:`ForceCurve`), :mod:`~skfem_sheet.switch.trace` (:func:`force_curve`),
:mod:`~skfem_sheet.switch.analysis` (:func:`switching`, :class:`Switching`)
and :mod:`~skfem_sheet.switch.force` (:func:`apply_tip_force`, the
force-controlled solve).
"""
from __future__ import annotations

from ..params import SIScale
from .analysis import Switching, switching
from .curve import CurvePoint, ForceCurve
from .force import TipForceRamp, apply_tip_force
from .trace import CURVE_HMAX, force_curve
from .trace import FOLD_TOLERANCE as FOLD_TOLERANCE
from .trace import FORCE_UNIT as FORCE_UNIT
from .trace import POLISH_UTOL as POLISH_UTOL
from .trace import TOLERANCES as TOLERANCES

__all__ = ["CURVE_HMAX", "CurvePoint", "ForceCurve", "SIScale", "Switching", "TipForceRamp",
           "apply_tip_force", "force_curve", "switching"]
