"""``skfem-sheet fold-curve``: the fold curve in (L, b/a) at one a/R, and its cusp.

The pop-up and standout folds of the bistable range are continued as one curve
in the plane of the length and the tip width (or, with ``--in curvature``, the
clamp curvature at a fixed tip width): the curve runs from ``L1*`` at
``b/a = 1`` down to the cusp, where the two folds meet, and back up as ``L0*``.
With ``--length`` (and ``--tip-width``), or a sheet in SI units (``--si``,
which also gives the curvature, thickness and modulus), the curve says where
that sheet sits: inside the curve (two states) or outside it (one).
See :mod:`skfem_sheet.foldcurve`.
"""
from __future__ import annotations

import json
import math

import numpy as np

from ..foldcurve import trace_curvature_fold_curve, trace_fold_curve
from ..io import Series, check_directory, check_writable, write_json
from ..params import ParameterError
from ..studies.foldmap import curve_halves
from .ranges import parse_range
from .solve import SI_HELP, planform_flags, solver_help

#: The defaults of the sheet's flags (``None`` in the parser, so that ``--si``
#: can tell which were given).
DEFAULTS = {"curvature": 2.5, "tip_width": 1.0, "thickness": 0.03, "modulus": 735.0}

__all__ = ["register", "run", "place", "DEFAULTS"]


def register(subparsers) -> None:
    """Add the ``fold-curve`` command."""
    p = subparsers.add_parser(
        "fold-curve", help="trace the fold curve in (L, b/a) at one a/R, with its cusp")
    p.add_argument("--curvature", type=float, default=None,
                   help="a/R, clamp curvature (default 2.5; with --in curvature: where the "
                        "curve starts)")
    p.add_argument("--in", dest="second", choices=("tip-width", "curvature"),
                   default="tip-width",
                   help="second parameter of the curve (default tip-width: at fixed a/R)")
    p.add_argument("--tip-width", type=float, default=None,
                   help="b/a: of the curve with --in curvature; of the sheet placed with "
                        "--length (default 1)")
    p.add_argument("--thickness", type=float, default=None, help="h/a (default 0.03)")
    p.add_argument("--modulus", type=float, default=None, help="E/(rho g a) (default 735)")
    p.add_argument("--length", type=float, default=None,
                   help="L/a of one sheet (of --tip-width, at --curvature): say where it sits "
                        "against the curve")
    p.add_argument("--si", default=None, metavar="NAME=VALUE,...",
                   help=SI_HELP.replace("the sheet", "one sheet") + "; its curvature and "
                        "material, and where it sits against the curve")
    p.add_argument("--hmax", type=float, default=0.1, help="mesh size (default 0.1)")
    p.add_argument("--layers", type=int, default=None)
    p.add_argument("--solver", default="auto", help=solver_help())
    p.add_argument("--start-length", type=float, default=None,
                   help="L/a of the first solve, below the pop-up length (default: from a/R, "
                        "1.2 at a/R = 2.5)")
    p.add_argument("--lengths", default="0.6:2.4",
                   help="the curve stops outside this range of L/a, short:long (default 0.6:2.4)")
    p.add_argument("--coarse-hmax", type=float, default=None,
                   help="coarse to fine: trace at this coarser mesh size first, then correct "
                        "points of it at --hmax (e.g. --hmax 0.03 --coarse-hmax 0.1)")
    p.add_argument("--fine-points", type=int, default=12,
                   help="with --coarse-hmax: points of the coarse curve corrected at --hmax "
                        "besides the ends and the cusp (default 12)")
    p.add_argument("--series", default=None, metavar="DIR",
                   help="write the state at every point of the curve as a ParaView time "
                        "series DIR/<name>.pvd (time: the point's index along the curve)")
    p.add_argument("--json", default=None, help="write the curve here")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=run)


def _sheet_flags(args):
    """Fill the flags from ``--si`` or the defaults; the sheet's ``(L/a, q)`` to
    place against the curve (q its tip width, or its curvature with ``--in
    curvature``), or None."""
    length = planform_flags(args, DEFAULTS)
    if length is None:
        return None
    return length, args.tip_width if args.second == "tip-width" else args.curvature


def place(curve, length, q) -> dict:
    """Where the sheet ``(length, q)`` sits against the traced ``curve``: the
    fold lengths at ``q`` interpolated on its two halves (``q``: the tip width,
    or the curvature of a curve in (L, a/R)); ``{"where", "states", "text"}``.

    ``where``: "between" (two states), "below" (shorter than L0*: one,
    curvature-dominated), "above" (longer than L1*: one, gravity-dominated),
    "beyond the cusp" (no bistable length at this q), or "unknown".
    """
    name = "b/a" if curve.second == "tip_width" else "a/R"
    j = curve.second
    cusp = curve.cusp or {}
    row = {"points": json.dumps([[p[j], p["length"], p["kind"]] for p in curve.points]),
           "second": j, "cusp_length": cusp.get("length", math.nan),
           "cusp_tip_width": cusp.get("tip_width", math.nan),
           "cusp_curvature": cusp.get("curvature", math.nan)}
    halves = curve_halves(row)
    at = f"L/a = {length:g}, {name} = {q:g}"
    if halves is None or halves["cusp"] is None or not len(halves["popup"][0]):
        return {"where": "unknown", "states": None,
                "text": f"{at}: unknown (the curve did not come back through its cusp)"}
    (qs, Ls), (qp, Lp) = halves["standout"], halves["popup"]
    q_cusp = halves["cusp"][0]
    if q < q_cusp:
        return {"where": "beyond the cusp", "states": 1,
                "text": f"{at}: {name} is below the cusp {name}* = {q_cusp:.3f}: one state at "
                        f"every length"}
    if q > min(qs.max(), qp.max()) + 1e-12:
        return {"where": "unknown", "states": None,
                "text": f"{at}: {name} lies beyond the traced curve"}
    L1, L0 = float(np.interp(q, qs, Ls)), float(np.interp(q, qp, Lp))
    folds = f"L0* = {L0:.3f}, L1* = {L1:.3f} at {name} = {q:g}, interpolated on the curve"
    if L0 < length < L1:
        return {"where": "between", "states": 2,
                "text": f"{at} lies inside the curve ({folds}): two states (bistable)"}
    if length <= L0:
        return {"where": "below", "states": 1,
                "text": f"{at} is below the pop-up length ({folds}): one state, "
                        f"curvature-dominated (aloft)"}
    return {"where": "above", "states": 1,
            "text": f"{at} is above the standout length ({folds}): one state, "
                    f"gravity-dominated (drooped)"}


def run(args) -> int:
    """Trace, print the folds at b/a = 1 and the cusp, write JSON."""
    if args.json:
        check_writable("--json", args.json, [".json"])
    sheet = _sheet_flags(args)
    lengths = parse_range(args.lengths, "lengths", pair="short:long", example="0.6:2.4")
    if not 0 < lengths[0] < lengths[1]:
        raise ParameterError(f"--lengths must be short:long with 0 < short < long, "
                             f"got {args.lengths!r}")
    series = None
    if args.series:
        check_directory("--series", args.series)
        series = Series()
    common = dict(hmax=args.hmax, start_length=args.start_length, length_range=lengths,
                  thickness=args.thickness, modulus=args.modulus, layers=args.layers,
                  solver=args.solver, progress=not args.quiet, coarse_hmax=args.coarse_hmax,
                  fine_points=args.fine_points, series=series)
    if args.second == "tip-width":
        curve = trace_fold_curve(args.curvature, **common)
        where = f"a/R = {args.curvature:g}"
        name = f"fold-curve_aR{args.curvature:g}"
    else:
        curve = trace_curvature_fold_curve(args.tip_width, args.curvature, **common)
        where = f"b/a = {args.tip_width:g}"
        name = f"fold-curve_ba{args.tip_width:g}_from_aR{args.curvature:g}"
    data = curve.summary()
    data.update(thickness=args.thickness, modulus=args.modulus, hmax=args.hmax)
    position = None if sheet is None or not curve.bistable else place(curve, *sheet)
    if position is not None:
        data["position"] = position
    if args.json:
        write_json(data, args.json)
    if series is not None and len(series):
        print(f"wrote {series.write(args.series, name)} ({len(series)} points)")
    cusp = curve.cusp
    cusp_text = "none" if cusp is None else ", ".join(f"{k} {v:.4f}" for k, v in cusp.items())
    coarse = ("" if curve.coarse_hmax is None else
              f" (from {curve.coarse_points} points at hmax {curve.coarse_hmax:g})")
    print(f"fold curve at {where}, h/a = {args.thickness:g}, E/(rho g a) = {args.modulus:g}; "
          f"hmax {args.hmax:g}{coarse}: {len(curve.points)} points, "
          f"{curve.factorizations} factorisations ({curve.factorizations_per_point:g} per point, "
          f"median), {curve.wall_time_s:.1f} s")
    def fmt(x):
        return "not on the curve" if x is None else f"{x:.4f}"

    print(f"standout L1* {fmt(curve.standout_length)}, pop-up L0* {fmt(curve.popup_length)}")
    print(f"cusp: {cusp_text}" + (f" (located by the {curve.cusp_located})"
                                  if curve.cusp_located else ""))
    if curve.remeshes:
        print(f"remeshed {curve.remeshes} times on the way")
    if position is not None:
        print(f"this sheet: {position['text']}")
    if not curve.bistable:
        print(curve.reason)
        return 0
    if not curve.completed:
        print(f"curve stopped: {curve.reason}")
        return 1
    return 0
