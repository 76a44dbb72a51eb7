"""The fold curve of a Sheet (:func:`fold_curve`): its fold lengths over the
tip width or the curvature, on :mod:`skfem_sheet.foldcurve`, traced coarse to
fine on the meshes :data:`FOLD_CURVE_LEVELS`.
"""
from __future__ import annotations

from ..params import DEFAULT_HMAX, ParameterError, Sheet, check_range
from .lengths import fold_range

#: Fold curves on meshes finer than the first of these are traced coarse to
#: fine: at that mesh size first, then points of it corrected level by level on
#: the finer ones and on the curve's own mesh (a step from hmax 0.1 straight to
#: 0.03 leaves some points outside the fold system's basin); the fold map's
#: curves too (:data:`skfem_sheet.studies.foldmap.COARSE_HMAX`).
FOLD_CURVE_LEVELS = (0.1, 0.06)
#: Points of the coarse curve refined on the fine meshes (besides its ends and
#: the cusp's neighbours).
FOLD_CURVE_POINTS = 6


def fold_curve(sheet: Sheet, hmax: float = DEFAULT_HMAX, *, second: str = "tip_width",
               lengths=None, progress: bool = False, **options):
    """The fold curve of a sheet's family: where its bistable window opens and closes.

    ``second="tip_width"``: the curve in (L, b/a) at the sheet's curvature
    (:func:`~skfem_sheet.foldcurve.trace_fold_curve`): ``L1*(b)`` from b/a =
    1 down to the cusp ``(b/a)*`` and back up as ``L0*(b)``.
    ``second="curvature"``: the curve in (L, a/R) at the sheet's tip width
    from its curvature down round the cusp where bistability starts
    (:func:`~skfem_sheet.foldcurve.trace_curvature_fold_curve`).  The
    thickness and modulus are the sheet's.  On meshes finer than
    :data:`FOLD_CURVE_LEVELS`' first the curve is traced coarse to fine, as
    the fold map's are.

    Parameters
    ----------
    sheet : Sheet
        A trapezoid (the curve maps its tip width; a planform has no b/a to
        vary).
    hmax : float
        Default :data:`~skfem_sheet.params.DEFAULT_HMAX`.
    second : {"tip_width", "curvature"}
    lengths : (float, float), optional
        The range of L/a of the curve (default 0.6 to 2.4, widened to hold
        the sheet's length).
    progress : bool
    **options
        Any other option of the trace (``min_tip_width``, ``min_curvature``,
        ``layers``, ``solver``, ``ds``, ``check_inertia``, ``coarse_hmax``,
        ``fine_points``, ``series``, ...).

    Returns
    -------
    FoldCurve
        ``standout_length``, ``popup_length`` (at b/a 1, or the sheet's
        curvature), ``cusp``, ``points``.

    Examples
    --------
    >>> c = fold_curve(Sheet(length=1.3, curvature=2.5), hmax=0.1)  # doctest: +SKIP
    >>> c.standout_length, c.popup_length, c.cusp  # doctest: +SKIP
    """
    from ..foldcurve import trace_curvature_fold_curve, trace_fold_curve

    if not isinstance(sheet, Sheet):
        raise ParameterError(f"sheet must be a skfem_sheet.Sheet, got {type(sheet).__name__}")
    if sheet.planform is not None:
        raise ParameterError("fold_curve maps a trapezoid's tip width: a sheet with a planform "
                             "has none to vary (fold_lengths gives its fold lengths)")
    if second not in ("tip_width", "curvature"):
        raise ParameterError(f"second must be 'tip_width' or 'curvature', got {second!r}")
    hmax = check_range("hmax", hmax, 0, None, lo_open=True)
    fine = hmax < FOLD_CURVE_LEVELS[0]
    kw = dict(thickness=sheet.thickness, modulus=sheet.modulus, progress=progress,
              length_range=fold_range(sheet.length, lengths),
              check_inertia=5 if fine else 10,
              coarse_hmax=FOLD_CURVE_LEVELS if fine else None, fine_points=FOLD_CURVE_POINTS)
    kw.update(options)
    if second == "tip_width":
        return trace_fold_curve(sheet.curvature, hmax, **kw)
    return trace_curvature_fold_curve(sheet.tip_width, sheet.curvature, hmax, **kw)
