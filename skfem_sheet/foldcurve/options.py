"""What a fold-curve trace is asked for (:class:`FoldCurveOptions`), and its fixed rules."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..engine import Tolerances
from ..sheet_shape import TOLERANCES

__all__ = ["FINE_TOLERANCES", "MAX_REMESHES", "MESH_LENGTH_GRID", "PREDICTOR", "REFILL_DS", "SECOND",
           "SEED_TOLERANCES", "SETTLE_STEP", "TARGET_CORRECTION", "TOLERANCES", "FoldCurveOptions",
           "default_start_length", "kind"]

#: Predictor of the fold-curve continuation (see :func:`skfem_sheet.engine.fold_curve`).
#: The tangent, with the iteration-count rule: Newton's basin for the thin
#: sheet is small, so the longer steps of a quadratic predictor fail and are
#: halved (``docs/decisions.md``, "The fold curves' predictor").
PREDICTOR = "tangent"
#: Step control by the first correction (None: by the iteration count).
TARGET_CORRECTION = None
#: Largest number of remeshes of one trace.
MAX_REMESHES = 40

#: The corrector's stopping rule for the points refined on a finer mesh (coarse
#: to fine): the returned point is the iterate plus its correction, once
#: that correction is below ``utol`` with the residual at the iterate within
#: ``rtol`` (a correction of 1e-5 a leaves residuals of 1e-2 of the weight,
#: more than :data:`TOLERANCES` allows), or once Newton's error estimate
#: from the contraction of the last two corrections puts the corrected
#: iterate within ``utol`` of the fold (``error_estimate``, see
#: :class:`~skfem_sheet.engine.Tolerances`): a fine point is then known to
#: about 1e-5 a, and the linearisation that would only confirm it is not
#: made (``docs/decisions.md``, "Error-estimate stops").
FINE_TOLERANCES = Tolerances(rtol=3e-2, utol=1e-5, max_iterations=10, max_correction=0.3,
                             error_estimate=True)

#: The settling of a state carried onto a finer mesh before its fold is
#: located from it (:func:`~skfem_sheet.foldcurve.refine.settled_fold`): one
#: Newton step of the equilibrium on the section of the null vector, taken
#: whatever its size up to :data:`FINE_TOLERANCES`' ``max_correction`` (the
#: settling is not converged to a tolerance).  What keeps the fold system
#: from converging from a carried state is its tangent: ``sigma`` and the
#: null vector are those of the tangent at the iterate, whose geometric
#: stiffness carries the membrane stress of the interpolated state (the
#: difference of two meshes, amplified by the membrane stiffness of a thin
#: sheet), not the stress of an equilibrium on the finer mesh.  One Newton
#: step of the equilibrium removes that stress to second order in the
#: carried state's error, and the fold system converges from there as from
#: the converged equilibrium (the records:
#: ``benchmarks/results/speed/speed_profile_curve_aR3.5_3155286.txt`` before,
#: ``benchmarks/results/speed/speed_profile_curve_aR3.5_8e95221.txt`` after).
SETTLE_STEP = Tolerances(rtol=np.inf, utol=FINE_TOLERANCES.max_correction, max_iterations=1,
                         max_correction=FINE_TOLERANCES.max_correction)

#: The corrector's stopping rule for the coarse trace of a curve refined
#: coarse to fine (its points only seed the finer levels, which correct
#: them again): :data:`TOLERANCES` with Newton's error estimate
#: (``error_estimate``, see :class:`~skfem_sheet.engine.Tolerances`), so that
#: a point is not linearised once more only to confirm it
#: (``docs/decisions.md``, "Error-estimate stops").
SEED_TOLERANCES = dataclasses.replace(TOLERANCES, error_estimate=True)

#: The fine meshes of a refinement are made at lengths on this grid (L/a):
#: the median of the lengths carried to a level, rounded.  A mesh made at
#: another length is another unstructured mesh, and at hmax 0.03 that moves
#: the fold lengths by up to 1e-4; on the grid the meshes, and
#: so the fine folds, do not follow round-off in the coarse points.  Any
#: length within a few per cent serves (a mesh covers a stretch of
#: REMESH_STRETCH either way).
MESH_LENGTH_GRID = 0.05

#: First and largest arclength step of the continuation on a fine mesh
#: that replaces an end which could not be refined
#: (:func:`skfem_sheet.foldcurve.refine.continue_to_end`).
REFILL_DS = (0.02, 0.2)

#: The second parameter of a curve, by its index ``j`` in ``(L, b, a/R)``:
#: ``(engine name, key of the curve's points)``.
SECOND = {1: ("b", "tip_width"), 2: ("a/R", "curvature")}


def kind(side) -> str:
    """The kind of a fold from the side its branch exists on: ``"standout"``
    (below the fold's length), ``"popup"`` (above) or ``"unknown"``.

    Examples
    --------
    >>> kind(-1), kind(1), kind(0)
    ('standout', 'popup', 'unknown')
    """
    return "standout" if side < 0 else "popup" if side > 0 else "unknown"


def default_start_length(curvature: float) -> float:
    """L/a of the first solve of a trace: below the pop-up length ``L0*(b = 1)``
    of the rectangle (hmax 0.1: 0.83, 0.97, 1.09, 1.21, 1.42, 1.72 at a/R = 1,
    1.5, 2, 2.5, 3.5, 5), so that the curvature-first solve is on the
    curvature-dominated branch; 1.2 at a/R = 2.5.

    Examples
    --------
    >>> [round(default_start_length(k), 3) for k in (1, 2.5, 5)]
    [0.6, 1.2, 1.6]
    """
    k = float(curvature)
    return float(min(1.2, 0.2 + 0.4 * k) if k <= 2.5 else 1.2 + 0.16 * (k - 2.5))


@dataclass(frozen=True)
class FoldCurveOptions:
    """How one fold curve is traced: the options of
    :func:`~skfem_sheet.foldcurve.trace_fold_curve` (which checks them), in one value.

    Attributes
    ----------
    hmax : float
        Mesh size of the curve (of its refined points, coarse to fine).
    start_length : float or None
        Length of the first solve, below ``L0*`` (None:
        :func:`default_start_length`, kept inside ``length_range``).
    length_range : (float, float)
    thickness, modulus : float
    layers : int or None
    solver : str
    ds, ds_max : float
        First and largest arclength step.
    check_inertia : bool or int
    mesh_length : float or None
        Length of the first mesh (None: ``1.08 start_length``).
    max_points : int
    progress : bool
    coarse_hmax : float, sequence of float or None
        Coarse to fine: the coarse mesh size(s).
    fine_points : int

    Examples
    --------
    >>> o = FoldCurveOptions(hmax=0.2)
    >>> o.length_range, o.check_inertia
    ((0.6, 2.4), 10)
    """

    hmax: float = 0.1
    start_length: float | None = None
    length_range: tuple = (0.6, 2.4)
    thickness: float = 0.03
    modulus: float = 735.0
    layers: int | None = None
    solver: str = "auto"
    ds: float = 0.05
    ds_max: float = 0.4
    check_inertia: object = 10
    mesh_length: float | None = None
    max_points: int = 400
    progress: bool = False
    coarse_hmax: object = None
    fine_points: int = 12

    @property
    def mesh_keywords(self) -> dict:
        """What a fresh :class:`~skfem_sheet.sheet_shape.SheetFoldProblem` of
        the curve takes besides the curvature and the mesh's shape."""
        return dict(thickness=self.thickness, modulus=self.modulus, layers=self.layers,
                    solver=self.solver)
