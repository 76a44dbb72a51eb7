"""``skfem-sheet bistability``: pop-up and standout lengths of a planform at a curvature.

The fold lengths L0* (pop-up) and L1* (standout) of a planform (a trapezoid
of tip width b/a, or a width profile from a CSV file) at a clamp curvature
a/R and a material (h/a, E/(rho g a)): the family of lengths is bistable
between them. Both branches are followed in L on a coarse mesh and their
ends located again on --hmax with the minimally augmented fold system (to
1e-6 in L/a, the eigenvalue that crosses zero confirmed). One sheet's length
(--length, or the sheet of --si, whose lengths are then printed in mm too)
is placed against them; solve --path both solves that sheet on both load
paths. Optional S-curve. With --at-length instead: continuation in the clamp
curvature at a fixed length, giving the critical curvatures.
"""
from __future__ import annotations

from ..bistability import fold_lengths, fold_range, follow_curvature, s_curve
from ..io import Series, check_directory, check_writable, write_json
from ..params import DEFAULT_HMAX, ParameterError, Sheet, read_planform_csv
from .ranges import parse_range
from .solve import SI_HELP, si_sheet, solver_help

__all__ = ["register", "run", "DEFAULTS"]

#: The defaults of the planform's flags (``None`` in the parser, so that
#: ``--si`` can tell which were given).
DEFAULTS = {"tip_width": 1.0, "curvature": 2.5, "thickness": 0.03, "modulus": 735.0}


def register(subparsers) -> None:
    """Add the ``bistability`` command."""
    p = subparsers.add_parser(
        "bistability", help="the lengths over which a planform at a curvature is bistable "
                            "(pop-up and standout lengths, located), optional S-curve",
        description=__doc__.split("\n\n")[1].replace("``", ""))
    p.add_argument("--tip-width", type=float, default=None,
                   help="b/a (1 rectangle, 0 triangle; default 1)")
    p.add_argument("--planform", default=None, metavar="FILE.csv",
                   help="a width profile instead of a trapezoid: CSV with columns x,width "
                        "(x from 0 to L; width 1 at x = 0)")
    p.add_argument("--curvature", type=float, default=None,
                   help="a/R, clamp curvature (default 2.5)")
    p.add_argument("--thickness", type=float, default=None, help="h/a (default 0.03)")
    p.add_argument("--modulus", type=float, default=None, help="E/(rho g a) (default 735)")
    p.add_argument("--length", type=float, default=None,
                   help="L/a of one sheet: say where it sits against the fold lengths")
    p.add_argument("--si", default=None, metavar="NAME=VALUE,...",
                   help=SI_HELP.replace("the sheet", "one sheet") + "; its planform, "
                        "curvature and material, and where its length sits (lengths also "
                        "in mm)")
    p.add_argument("--lengths", default=None,
                   help="range of L/a searched, short:long (default 0.6:2.4, widened to "
                        "hold the sheet's length)")
    p.add_argument("--hmax", type=float, default=DEFAULT_HMAX,
                   help=f"mesh size the folds are located on (default {DEFAULT_HMAX:g}, the "
                        f"paper's; 0.1 for a quick look)")
    p.add_argument("--coarse-hmax", type=float, default=None,
                   help="mesh the branches are traced on before their ends are located on "
                        "--hmax (default 0.1 where --hmax is finer, else --hmax); 0: none, "
                        "everything on --hmax")
    p.add_argument("--branches", action="store_true",
                   help="also follow both branches on --hmax up to their folds (the curves "
                        "d(L) of the figures; implied by --series)")
    p.add_argument("--layers", type=int, default=None)
    p.add_argument("--solver", default="auto", help=solver_help())
    p.add_argument("--step", type=float, default=0.1, help="largest length step (default 0.1)")
    p.add_argument("--min-step", type=float, default=None,
                   help="shortest step tried before a branch is given up where no fold is "
                        "located (default 0.005)")
    p.add_argument("--tol", type=float, default=None,
                   help="deprecated (the old fold bracket): read as --min-step")
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


def _sheet(args) -> Sheet:
    """The sheet of the command: from ``--si`` (its length too; the SI input
    and the dimensionless parameters are printed), or from the planform's
    flags (``--planform`` or ``--tip-width``) and ``--length``."""
    given = [k for k in DEFAULTS if getattr(args, k) is not None]
    if args.si is not None:
        flags = ["--" + k.replace("_", "-") for k in given]
        flags += [flag for flag, value in (("--length", args.length),
                                           ("--at-length", args.at_length),
                                           ("--planform", args.planform)) if value is not None]
        if flags:
            raise ParameterError(f"--si cannot be combined with {', '.join(flags)} (give every "
                                 f"quantity in --si, in SI units)")
        return si_sheet(args.si)
    if args.length is not None and args.at_length is not None:
        raise ParameterError("--length cannot be combined with --at-length (the length of "
                             "the continuation in the curvature)")
    if args.planform is not None and "tip_width" in given:
        raise ParameterError("--tip-width cannot be combined with --planform "
                             "(the planform gives the width)")
    for k, v in DEFAULTS.items():
        if getattr(args, k) is None:
            setattr(args, k, v)
    material = dict(curvature=args.curvature, thickness=args.thickness, modulus=args.modulus)
    L = args.at_length if args.at_length is not None else args.length
    if args.planform is not None:
        pf = read_planform_csv(args.planform)
        return Sheet.from_planform(pf, length=L if L is not None else pf.length, **material)
    return Sheet(length=L if L is not None else 1.0, tip_width=args.tip_width, **material)


def _range(args, sheet, placed):
    """``--lengths`` (checked to hold the sheet's length if one is placed), or
    the default widened to hold it."""
    if args.lengths is None:
        return fold_range(sheet.length) if placed else (0.6, 2.4)
    lo, hi = parse_range(args.lengths, "lengths", pair="short:long", example="0.6:2.4")
    if placed and not lo <= sheet.length <= hi:
        raise ParameterError(f"lengths must hold the sheet's length L/a = {sheet.length:g}, "
                             f"got {args.lengths!r}")
    return lo, hi


def run(args) -> int:
    """Fold lengths (or, with ``--at-length``, critical curvatures); print, write JSON."""
    if args.json:
        check_writable("--json", args.json, [".json"])
    if args.series:
        check_directory("--series", args.series)
    sheet = _sheet(args)
    if args.at_length is not None:
        return _run_curvature(args, sheet)
    placed = args.length is not None or args.si is not None or args.planform is not None
    lo, hi = _range(args, sheet, placed)
    if not placed:  # the family only: the sheet's length is the start of the range
        sheet = sheet.replace(length=lo)
    series = (Series(), Series()) if args.series else (None, None)
    min_step = args.min_step if args.min_step is not None else args.tol
    f = fold_lengths(sheet, hmax=args.hmax, lengths=(lo, hi), branches=args.branches,
                     coarse_hmax=args.coarse_hmax, step=args.step, layers=args.layers,
                     solver=args.solver, progress=not args.quiet, min_step=min_step,
                     on_point=tuple(None if x is None else x.on_point for x in series))
    lines = f.lines()
    if not placed:
        lines = lines[:-1]
    for line in lines:
        print(line)
    data = f.summary()
    if not placed:
        data["position"] = None
        data["in_window"] = None
    if args.series:
        down = f.decreasing if len(series[1]) else None  # one branch traced once
        _write_series(args.series, [("curvature-dominated", f.increasing, series[0]),
                                    ("gravity-dominated", down, series[1])])
    if args.s_curve and f.bistable:
        a, b = f.popup_length, f.standout_length
        start, stop = max(lo, a - 0.15), min(hi, b + 0.15)
        sc_series = Series() if args.series else None
        sc = s_curve(sheet.replace(length=start), stop, hmax=args.hmax, layers=args.layers,
                     solver=args.solver,
                     on_point=None if sc_series is None else sc_series.on_point)
        data["s_curve"] = sc.summary()
        print(f"  S-curve: {len(sc.points)} points, folds at L/a = "
              + ", ".join(f"{x:.5f}" for x in sc.folds))
        if sc_series is not None:
            _write_series(args.series, [("s-curve", sc, sc_series)])
    if args.json:
        write_json(data, args.json)
        print(f"  wrote {args.json}")
    return 0


def _run_curvature(args, sheet) -> int:
    k_lo, k_hi = parse_range(args.curvatures, "curvatures", pair="low:high", example="0.5:5")
    if not 0 <= k_lo < k_hi:
        raise ParameterError(f"curvatures must be low:high with 0 <= low < high, got "
                             f"{args.curvatures!r}")
    base = sheet.replace(curvature=k_lo)
    kw = dict(hmax=args.hmax, layers=args.layers, solver=args.solver,
              min_step=args.min_step if args.min_step is not None else args.tol)
    series = (Series(), Series()) if args.series else (None, None)
    up = follow_curvature(base, k_hi, path="gravity-first", **kw,
                          on_point=None if series[0] is None else series[0].on_point)
    down = follow_curvature(base.replace(curvature=k_hi), k_lo, path="curvature-first", **kw,
                            on_point=None if series[1] is None else series[1].on_point)
    k0, k1 = up.fold, down.fold
    bistable = bool(k0 is not None and k1 is not None and k1 < k0)

    def fmt(x):
        return "none in range" if x is None else f"{x:.5f} (located)"

    def why(b, what):
        if b.fold is not None:
            return f"(the {what} branch ends there)"
        return f"({b.reason})" if b.reason else f"(the {what} branch held)"

    print(f"L/a = {sheet.length:g}, {sheet.describe().split(', ', 1)[1].split(', a/R')[0]}, "
          f"h/a = {sheet.thickness:g}, E/(rho g a) = {sheet.modulus:g}; hmax {args.hmax:g}, "
          f"a/R searched in [{k_lo:g}, {k_hi:g}]:")
    print(f"  pop-up curvature a/R0* = {fmt(k0)}  {why(up, 'gravity-dominated')}")
    print(f"  fall curvature   a/R1* = {fmt(k1)}  {why(down, 'curvature-dominated')}")
    if sheet.si is not None:
        for name, k in (("R0*", k0), ("R1*", k1)):
            if k is not None and k > 0:
                print(f"  {name} = {1e3 * sheet.si.base_width / k:.5g} mm")
    text = f"this sheet (L/a = {sheet.length:g})"
    print(f"  {text} is bistable for {k1:.5f} < a/R < {k0:.5f}: two stable states at each "
          f"curvature in between" if bistable else
          f"  {text} is not bistable for any a/R in [{k_lo:g}, {k_hi:g}] searched")
    if args.series:
        _write_series(args.series, [("gravity-dominated", up, series[0]),
                                    ("curvature-dominated", down, series[1])])
    if args.json:
        def branch(b):
            return {"curvatures": b.lengths.tolist(), "deflection": b.deflections.tolist(),
                    "stable": b.stable, "fold": b.fold, "fold_deflection": b.fold_deflection,
                    "bracket": list(b.bracket), "reason": b.reason}

        si = sheet.si
        write_json({"length": sheet.length, "tip_width": sheet.tip_width,
                    "thickness": sheet.thickness, "modulus": sheet.modulus,
                    "sheet": sheet.to_dict(),
                    "popup_curvature": k0, "fall_curvature": k1, "bistable": bistable,
                    "gravity_dominated": branch(up), "curvature_dominated": branch(down),
                    "si": None if si is None else {
                        "popup_radius_m": None if not k0 else si.base_width / k0,
                        "fall_radius_m": None if not k1 else si.base_width / k1}},
                   args.json)
        print(f"  wrote {args.json}")
    return 0


def _write_series(directory, items) -> None:
    """Write ``(name, curve, series)`` items (a ``None`` curve is skipped) and say so."""
    for name, curve, series in items:
        if curve is not None and len(series):
            pvd = curve.write_series(directory, name, series)
            print(f"  wrote {pvd} ({len(series)} points)")
