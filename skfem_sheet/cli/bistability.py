"""``skfem-sheet bistability``: pop-up and standout lengths of a planform at a curvature.

The fold lengths ``L0*`` (pop-up) and ``L1*`` (standout) of a trapezoid (tip
width b/a) at a clamp curvature a/R: the planform at that curvature is
bistable for lengths between them.  That is a property of the family of
lengths; ``--length`` (or a sheet in SI units, ``--si``) says where one
sheet's length sits against them (``solve --path both`` solves that sheet on
both load paths).  Optional S-curve.  With ``--at-length`` instead:
continuation in the clamp curvature at a fixed length, giving the critical
curvatures.  See :mod:`skfem_sheet.bistability`.
"""
from __future__ import annotations

from ..bistability import fold_lengths, follow_curvature, s_curve
from ..io import Series, check_directory, check_writable, write_json
from ..params import ParameterError, Sheet
from ..states import fold_position
from ..studies.foldmap import row_coarse_hmax
from .ranges import parse_range
from .solve import SI_HELP, planform_flags, solver_help

__all__ = ["register", "run", "DEFAULTS"]

#: The defaults of the planform's flags (``None`` in the parser, so that
#: ``--si`` can tell which were given).
DEFAULTS = {"tip_width": 1.0, "curvature": 2.5, "thickness": 0.03, "modulus": 735.0}


def register(subparsers) -> None:
    """Add the ``bistability`` command."""
    p = subparsers.add_parser(
        "bistability", help="the lengths over which a planform at a curvature is bistable "
                            "(pop-up and standout lengths), optional S-curve",
        description=__doc__.split("\n\n")[1].replace("``", ""))
    p.add_argument("--tip-width", type=float, default=None,
                   help="b/a (1 rectangle, 0 triangle; default 1)")
    p.add_argument("--curvature", type=float, default=None,
                   help="a/R, clamp curvature (default 2.5)")
    p.add_argument("--thickness", type=float, default=None, help="h/a (default 0.03)")
    p.add_argument("--modulus", type=float, default=None, help="E/(rho g a) (default 735)")
    p.add_argument("--length", type=float, default=None,
                   help="L/a of one sheet: say where it sits against the fold lengths")
    p.add_argument("--si", default=None, metavar="NAME=VALUE,...",
                   help=SI_HELP.replace("the sheet", "one sheet") + "; its planform, "
                        "curvature and material, and where its length sits")
    p.add_argument("--lengths", default=None,
                   help="range of L/a searched, short:long (default 0.6:2.4, widened to "
                        "hold --length)")
    p.add_argument("--hmax", type=float, default=0.06, help="mesh size (default 0.06)")
    p.add_argument("--coarse-hmax", type=float, default=None,
                   help="trace both branches on this coarser mesh first and follow them on "
                        "--hmax from there (the coarse states start the fine branches and "
                        "correct each step's prediction; same equilibria, fewer fine "
                        "factorisations); 0: none, the branches on --hmax alone. Default: the "
                        "fold map's rule, hmax 0.1 for --hmax 0.05 and finer, none above")
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


def _planform(args):
    """Fill the planform's flags in ``args`` (from ``--si``, or the defaults);
    the sheet's length to place (``--length`` or the SI sheet's), or None."""
    length = planform_flags(args, DEFAULTS, also=(("--at-length", args.at_length),))
    if length is not None and args.at_length is not None:
        raise ParameterError("--length cannot be combined with --at-length (the length of "
                             "the continuation in the curvature)")
    return length


def _range(args, length):
    """``--lengths`` (checked to hold ``length``), or its default widened to hold it."""
    if args.lengths is None:
        if length is None:
            return 0.6, 2.4
        return min(0.6, 0.8 * length), max(2.4, min(20.0, 1.25 * length))
    lo, hi = parse_range(args.lengths, "lengths", pair="short:long", example="0.6:2.4")
    if length is not None and not lo < length < hi:
        raise ParameterError(f"lengths must hold the sheet's length L/a = {length:g}, got "
                             f"{args.lengths!r}")
    return lo, hi


def _fold_text(r, which):
    """One fold length and what it is, for the table (no solver jargon)."""
    b = r.increasing if which == "standout" else r.decreasing
    x = r.standout_length if which == "standout" else r.popup_length
    branch = "curvature-dominated" if which == "standout" else "gravity-dominated"
    lo, hi = r.length_range
    if x is not None:
        return f"{x:.3f} +- {r.tol:g}  (the {branch} branch ends there)"
    if b.start_snapped:
        end = lo if which == "standout" else hi
        return (f"none: the {branch} branch does not exist at L/a = {end:g}, where it was "
                f"started (widen --lengths)")
    if b.reason:
        return f"not found: the {branch} branch was lost for another reason ({b.reason})"
    end = hi if which == "standout" else lo
    return f"none in range (the {branch} branch held to L/a = {end:g})"


def run(args) -> int:
    """Fold lengths (or, with ``--at-length``, critical curvatures); print, write JSON."""
    if args.json:
        check_writable("--json", args.json, [".json"])
    if args.series:
        check_directory("--series", args.series)
    length = _planform(args)
    Sheet(length=length or 1.0, tip_width=args.tip_width, curvature=args.curvature,
          thickness=args.thickness, modulus=args.modulus)  # validates the parameters
    if args.at_length is not None:
        return _run_curvature(args)
    lo, hi = _range(args, length)
    series = (Series(), Series()) if args.series else (None, None)
    r = fold_lengths(args.tip_width, args.curvature, lengths=(lo, hi), hmax=args.hmax,
                     layers=args.layers, solver=args.solver, step=args.step, tol=args.tol,
                     thickness=args.thickness, modulus=args.modulus, progress=not args.quiet,
                     on_point=tuple(None if x is None else x.on_point for x in series),
                     coarse_hmax=(row_coarse_hmax(args.hmax) if args.coarse_hmax is None
                                  else args.coarse_hmax or None))
    data = r.summary()
    data["thickness"], data["modulus"] = args.thickness, args.modulus
    print(f"planform b/a = {args.tip_width:g} at a/R = {args.curvature:g}, h/a = "
          f"{args.thickness:g}, E/(rho g a) = {args.modulus:g}; hmax {args.hmax:g}, L/a "
          f"searched in [{lo:g}, {hi:g}]  ({r.wall_time_s:.0f} s):")
    print(f"  standout length L1*/a = {_fold_text(r, 'standout')}")
    print(f"  pop-up length   L0*/a = {_fold_text(r, 'popup')}")
    family = f"this planform (b/a = {args.tip_width:g}) at a/R = {args.curvature:g}"
    if r.bistable:
        print(f"  {family} is bistable for {r.popup_length:.3f} < L/a < "
              f"{r.standout_length:.3f}: two stable states at each length in between")
    elif r.popup_length is not None and r.standout_length is not None \
            and r.standout_length > r.popup_length:
        print(f"  {family}: the folds are closer than twice their resolution ({r.tol:g}): "
              f"no bistable range is claimed")
    else:
        print(f"  {family} is not bistable for any L/a in [{lo:g}, {hi:g}] searched")
    if length is not None:
        pos = fold_position(r, length)
        data["position"] = pos.to_json()
        print(f"  this sheet: {pos.text}")
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

    def why(b, what):
        if b.fold is not None:
            return f"(the {what} branch ends there)"
        return f"({b.reason})" if b.reason else f"(the {what} branch held)"

    print(f"L/a = {args.at_length:g}, b/a = {args.tip_width:g}, h/a = {args.thickness:g}, "
          f"E/(rho g a) = {args.modulus:g}; hmax {args.hmax:g}, a/R searched in "
          f"[{k_lo:g}, {k_hi:g}]:")
    print(f"  pop-up curvature a/R0* = {fmt(k0)}  {why(up, 'gravity-dominated')}")
    print(f"  fall curvature   a/R1* = {fmt(k1)}  {why(down, 'curvature-dominated')}")
    sheet = f"this sheet (L/a = {args.at_length:g}, b/a = {args.tip_width:g})"
    print(f"  {sheet} is bistable for {k1:.3f} < a/R < {k0:.3f}: two stable states at each "
          f"curvature in between" if bistable else
          f"  {sheet} is not bistable for any a/R in [{k_lo:g}, {k_hi:g}] searched")
    if args.series:
        _write_series(args.series, [("gravity-dominated", up, series[0]),
                                    ("curvature-dominated", down, series[1])])
    if args.json:
        def branch(b):
            return {"curvatures": b.lengths.tolist(), "deflection": b.deflections.tolist(),
                    "stable": b.stable, "fold": b.fold,
                    "bracket": list(b.bracket), "reason": b.reason}

        write_json({"length": args.at_length, "tip_width": args.tip_width,
                    "thickness": args.thickness, "modulus": args.modulus,
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
