"""``skfem-sheet bistability``: pop-up and standout lengths of one sheet, optional S-curve.

With ``--at-length`` instead: continuation in the clamp curvature at a fixed
length, giving the critical curvatures.  See :mod:`skfem_sheet.bistability`.
"""
from __future__ import annotations

from ..bistability import fold_lengths, follow_curvature, s_curve
from ..io import Series, check_directory, check_writable, write_json
from ..params import ParameterError, Sheet
from .ranges import parse_range
from .solve import solver_help

__all__ = ["register", "run"]


def register(subparsers) -> None:
    """Add the ``bistability`` command."""
    p = subparsers.add_parser(
        "bistability", help="pop-up and standout lengths (continuation in L), optional S-curve")
    p.add_argument("--tip-width", type=float, default=1.0, help="b/a (1 rectangle, 0 triangle)")
    p.add_argument("--curvature", type=float, default=2.5, help="a/R, clamp curvature")
    p.add_argument("--thickness", type=float, default=0.03, help="h/a (default 0.03)")
    p.add_argument("--modulus", type=float, default=735.0, help="E/(rho g a) (default 735)")
    p.add_argument("--lengths", default="0.6:2.4",
                   help="range of L/a searched, short:long (default 0.6:2.4)")
    p.add_argument("--hmax", type=float, default=0.06, help="mesh size (default 0.06)")
    p.add_argument("--layers", type=int, default=None)
    p.add_argument("--solver", default="auto", help=solver_help())
    p.add_argument("--step", type=float, default=0.1, help="largest length step (default 0.1)")
    p.add_argument("--tol", type=float, default=0.005,
                   help="fold bracket half-width (default 0.005)")
    p.add_argument("--at-length", type=float, default=None,
                   help="instead: continuation in the curvature at this L/a, giving the "
                        "critical curvatures a/R0* (pop-up) and a/R1* (fall)")
    p.add_argument("--curvatures", default="0.5:5",
                   help="with --at-length: range of a/R searched, low:high (default 0.5:5)")
    p.add_argument("--s-curve", action="store_true",
                   help="also trace the whole S-curve by pseudo-arclength continuation")
    p.add_argument("--json", default=None, help="write the result here")
    p.add_argument("--series", default=None, metavar="DIR",
                   help="write each branch as a ParaView time series: "
                        "DIR/curvature-dominated.pvd, DIR/gravity-dominated.pvd (and "
                        "DIR/s-curve.pvd), one VTU per point (time: the length, or the "
                        "curvature with --at-length, or the distance travelled in it)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(run=run)


def run(args) -> int:
    """Fold lengths (or, with ``--at-length``, critical curvatures); print, write JSON."""
    if args.json:
        check_writable("--json", args.json, [".json"])
    if args.series:
        check_directory("--series", args.series)
    Sheet(length=1.0, tip_width=args.tip_width, curvature=args.curvature,
          thickness=args.thickness, modulus=args.modulus)  # validates the parameters
    if args.at_length is not None:
        return _run_curvature(args)
    lo, hi = parse_range(args.lengths, "lengths", pair="short:long", example="0.6:2.4")
    series = (Series(), Series()) if args.series else (None, None)
    r = fold_lengths(args.tip_width, args.curvature, lengths=(lo, hi), hmax=args.hmax,
                     layers=args.layers, solver=args.solver, step=args.step, tol=args.tol,
                     thickness=args.thickness, modulus=args.modulus, progress=not args.quiet,
                     on_point=tuple(None if x is None else x.on_point for x in series))
    data = r.summary()

    def fmt(x):
        return "none in range" if x is None else f"{x:.3f} +- {r.tol:g}"

    print(f"b/a = {args.tip_width:g}, a/R = {args.curvature:g}, hmax = {args.hmax:g}:")
    print(f"  standout length L1*/a = {fmt(r.standout_length)}  ({r.increasing.reason or 'held'})")
    print(f"  pop-up length   L0*/a = {fmt(r.popup_length)}  ({r.decreasing.reason or 'held'})")
    print(f"  bistable: {'yes' if r.bistable else 'no'}  ({r.wall_time_s:.0f} s)")
    if args.series:
        down = r.decreasing if len(series[1]) else None  # a flat clamp: one branch
        _write_series(args.series, [("curvature-dominated", r.increasing, series[0]),
                                    ("gravity-dominated", down, series[1])])
    if args.s_curve and r.bistable:
        a, b = r.popup_length, r.standout_length
        start, stop = max(lo, a - 0.15), min(hi, b + 0.15)
        sc_series = Series() if args.series else None
        sc = s_curve(Sheet(length=start, tip_width=args.tip_width, curvature=args.curvature,
                           thickness=args.thickness, modulus=args.modulus), stop,
                     hmax=args.hmax, layers=args.layers, solver=args.solver,
                     on_point=None if sc_series is None else sc_series.on_point)
        data["s_curve"] = sc.summary()
        print(f"  S-curve: {len(sc.points)} points, folds at L/a = "
              + ", ".join(f"{x:.3f}" for x in sc.folds))
        if sc_series is not None:
            _write_series(args.series, [("s-curve", sc, sc_series)])
    if args.json:
        write_json(data, args.json)
        print(f"  wrote {args.json}")
    return 0


def _run_curvature(args) -> int:
    k_lo, k_hi = parse_range(args.curvatures, "curvatures", pair="low:high", example="0.5:5")
    if not 0 <= k_lo < k_hi:
        raise ParameterError(f"curvatures must be low:high with 0 <= low < high, got "
                             f"{args.curvatures!r}")
    base = Sheet(length=args.at_length, tip_width=args.tip_width, curvature=k_lo,
                 thickness=args.thickness, modulus=args.modulus)
    kw = dict(hmax=args.hmax, layers=args.layers, solver=args.solver, tol=args.tol)
    series = (Series(), Series()) if args.series else (None, None)
    up = follow_curvature(base, k_hi, path="gravity-first", **kw,
                          on_point=None if series[0] is None else series[0].on_point)
    down = follow_curvature(base.replace(curvature=k_hi), k_lo, path="curvature-first", **kw,
                            on_point=None if series[1] is None else series[1].on_point)
    k0, k1 = up.fold, down.fold
    bistable = bool(k0 is not None and k1 is not None and k1 < k0)

    def fmt(x):
        return "none in range" if x is None else f"{x:.3f} +- {args.tol:g}"

    print(f"L/a = {args.at_length:g}, b/a = {args.tip_width:g}, hmax = {args.hmax:g}:")
    print(f"  pop-up curvature a/R0* = {fmt(k0)}  ({up.reason or 'held'})")
    print(f"  fall curvature   a/R1* = {fmt(k1)}  ({down.reason or 'held'})")
    print(f"  bistable for a/R1* < a/R < a/R0*: {'yes' if bistable else 'no'}")
    if args.series:
        _write_series(args.series, [("gravity-dominated", up, series[0]),
                                    ("curvature-dominated", down, series[1])])
    if args.json:
        def branch(b):
            return {"curvatures": b.lengths.tolist(), "deflection": b.deflections.tolist(),
                    "stable": b.stable, "fold": b.fold,
                    "bracket": list(b.bracket), "reason": b.reason}

        write_json({"length": args.at_length, "tip_width": args.tip_width,
                    "popup_curvature": k0, "fall_curvature": k1, "bistable": bistable,
                    "gravity_dominated": branch(up), "curvature_dominated": branch(down)},
                   args.json)
        print(f"  wrote {args.json}")
    return 0


def _write_series(directory, items) -> None:
    """Write ``(name, curve, series)`` items (a ``None`` curve is skipped) and say so."""
    for name, curve, series in items:
        if curve is not None and len(series):
            pvd = curve.write_series(directory, name, series)
            print(f"  wrote {pvd} ({len(series)} points)")
