"""``skfem-sheet solve``: one sheet along one load path, or both (also the code path of ``demo``).

The sheet is given either in its dimensionless parameters (``--length``,
``--tip-width``, ...) or in SI units with one flag, ``--si
base_width=0.05,length=0.065,tip_width=0.05,thickness=1.5875e-3,radius=0.02,
youngs_modulus=4.5e5,density=1250`` (``gravity`` optional, default 9.81;
metres, Pa, kg/m^3, m/s^2; ``radius=inf`` for a flat clamp), mapped through
``Sheet.from_si``; the dimensionless parameters it
gives are printed, and the answers come in SI units too.  ``--path both``
solves both load paths and says whether the two end states differ (is this
sheet bistable?), with both deflections, their names and stability (in
Python: skfem_sheet.solve_both); ``--folds`` adds the fold lengths of its
planform at its curvature and where its length sits against them.
"""
from __future__ import annotations

import inspect
import math
from dataclasses import replace

from ..analyses.sensitivity import SI_UNITS
from ..continuation import PATHS
from ..io import Series, check_directory, check_writable
from ..linalg import SOLVERS
from ..params import ParameterError, Sheet, read_planform_csv
from ..plot import plot_sheet
from ..solve import STARTS, CoarseStart, solve
from ..starts import COARSE_HMAX, COARSEST_HMAX
from ..states import sheet_line, solve_both, with_path
from .ranges import parse_range

__all__ = ["register", "run", "run_both", "add_sheet_args", "add_solve_args", "parse_si",
           "sheet_from_args", "si_sheet", "si_base_width", "SHEET_DEFAULTS", "SI_NAMES",
           "SI_HELP", "solver_help"]

#: The defaults of the dimensionless sheet flags (``None`` in the parser, so
#: that ``--si`` can tell which were given).
SHEET_DEFAULTS = {"tip_width": 1.0, "curvature": 0.0, "thickness": 0.03, "modulus": 735.0}

#: The keys of ``--si``: the parameters of :meth:`Sheet.from_si`, in order.
SI_NAMES = tuple(inspect.signature(Sheet.from_si).parameters)

#: Help text of ``--si`` (every command that takes a sheet).
SI_HELP = ("the sheet in SI units instead: " + ", ".join(f"{n}=" for n in SI_NAMES)
           + " (metres, Pa, kg/m^3, m/s^2; gravity optional, default 9.81; radius=inf: "
             "flat clamp), e.g. base_width=0.05,length=0.065,tip_width=0.05,"
             "thickness=1.5875e-3,radius=0.02,youngs_modulus=4.5e5,density=1250")

_SI_REQUIRED = tuple(n for n, p in inspect.signature(Sheet.from_si).parameters.items()
                     if p.default is inspect.Parameter.empty)


def solver_help(plural: bool = False) -> str:
    """Help text of ``--solver``: every name of :data:`skfem_sheet.linalg.SOLVERS`."""
    return (f"linear solver{'s (comma list)' if plural else ''}: {', '.join(SOLVERS)} "
            f"(default auto: pardiso if installed, else superlu)")


def add_sheet_args(p, length=None) -> None:
    """The sheet's parameters (``--length`` or ``--si`` required unless ``length`` is given)."""
    if length is None:
        g = p.add_mutually_exclusive_group(required=True)
        g.add_argument("--length", type=float, help="L/a, sheet length in base widths")
        g.add_argument("--si", default=None, metavar="NAME=VALUE,...", help=SI_HELP)
        g.add_argument("--planform", default=None, metavar="FILE.csv",
                       help="a width profile instead of a trapezoid: CSV with columns x,width "
                            "(x from 0 to L, L taken from the last x; width 1 at x = 0)")
    else:
        p.add_argument("--length", type=float, default=length,
                       help=f"L/a, sheet length in base widths (default {length:g})")
        p.set_defaults(si=None, planform=None)
    p.add_argument("--tip-width", type=float, default=None,
                   help="b/a (1 rectangle, 0 triangle; default 1)")
    p.add_argument("--curvature", type=float, default=None, help="a/R, clamp curvature (default 0)")
    p.add_argument("--thickness", type=float, default=None, help="h/a (default 0.03)")
    p.add_argument("--modulus", type=float, default=None, help="E/(rho g a) (default 735)")


def add_solve_args(p, hmax=0.03) -> None:
    """The solve's options and output files."""
    p.add_argument("--path", default="curvature-first",
                   help="load path: curvature-first (aloft branch), gravity-first (drooped), "
                        "or both: both paths, and whether their end states differ (is this "
                        "sheet bistable?)")
    p.add_argument("--folds", nargs="?", const="auto", default=None, metavar="SHORT:LONG",
                   help="with --path both: also find the fold lengths L0*, L1* of this "
                        "planform at this curvature and material (its branches in L/a over "
                        "SHORT:LONG, default 0.6:2.4 widened to hold the length, their ends "
                        "located on --hmax) and say where the sheet's length sits")
    p.add_argument("--hmax", type=float, default=hmax, help=f"mesh size (default {hmax})")
    p.add_argument("--layers", type=int, default=None, help="element layers through the thickness")
    p.add_argument("--refine", type=int, default=0,
                   help="nested refinement: halve every edge this many times (0-4, default 0)")
    p.add_argument("--full-sheet", action="store_true",
                   help="solve the whole sheet (admits asymmetric shapes) instead of the "
                        "mirror-symmetric half")
    p.add_argument("--solver", default="auto", help=solver_help())
    p.add_argument("--start", default=None, choices=STARTS,
                   help="coarse (default): the load path on the mesh --coarse-hmax, its folds "
                        "located again on --hmax (the sheet snaps there where they lie inside "
                        "their phase) and its end state finished on --hmax by Newton (the "
                        "whole path runs on --hmax where that fails); path: the load path on "
                        "the mesh --hmax (the default with --series, which then holds every "
                        "load step)")
    p.add_argument("--coarse-hmax", type=float, default=CoarseStart.hmax,
                   help=f"mesh size of the coarse path of --start coarse (default: "
                        f"{CoarseStart.min_coarsening:g} times --hmax, at least {COARSE_HMAX:g} "
                        f"and at most {COARSEST_HMAX:g}; used where it is at least "
                        f"{CoarseStart.min_coarsening:g} times --hmax; closer, the path runs "
                        f"on --hmax)")
    p.add_argument("--gravity", type=float, default=1.0,
                   help="gravity as a fraction of the sheet's own weight, 0 to 10 "
                        "(default 1; 0: no gravity)")
    p.add_argument("--json", default=None, help="write a JSON summary here")
    p.add_argument("--vtu", default=None, help="write the deformed sheet (VTU, ParaView) here")
    p.add_argument("--png", default=None, help="write a picture of the deformed sheet here")
    p.add_argument("--series", default=None, metavar="DIR",
                   help="write every load step as a ParaView time series: DIR/<path>.pvd "
                        "and DIR/<path>/<path>_NNNN.vtu (time: the load parameter)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--sensitivities", default=None, metavar="NAME,...",
                   help="derivatives of d (and of the energy and the tip angle) by these "
                        "parameters: modulus, thickness, curvature, gravity, length, tip_width "
                        "(in --json under 'sensitivities'; with --si also in SI units; with "
                        "--path both one set per path)")


def register(subparsers) -> None:
    """Add the ``solve`` command."""
    p = subparsers.add_parser("solve", help="solve one sheet along one load path",
                              description=__doc__.split("\n\n")[1].replace("``", ""))
    add_sheet_args(p)
    add_solve_args(p)
    p.set_defaults(run=run)


def parse_si(text) -> dict:
    """Parse ``--si`` text, ``name=value,...``, into the arguments of :meth:`Sheet.from_si`.

    Raises ``ParameterError`` naming ``--si`` (and the key) on unknown, repeated,
    missing or non-numeric entries.

    Examples
    --------
    >>> parse_si("base_width=0.05, length=0.065, tip_width=0.05, thickness=1.5875e-3, "
    ...          "radius=inf, youngs_modulus=4.5e5, density=1250")["radius"]
    inf
    """
    out = {}
    for item in str(text).split(","):
        item = item.strip()
        if not item:
            continue
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep:
            raise ParameterError(f"--si must be name=value,... with names from "
                                 f"{', '.join(SI_NAMES)}, got {item!r}")
        if key not in SI_NAMES:
            raise ParameterError(f"--si {key!r} is not one of {', '.join(SI_NAMES)}")
        if key in out:
            raise ParameterError(f"--si {key} is given twice")
        try:
            x = float(value)
        except ValueError:
            raise ParameterError(f"--si {key} must be a number, got {value.strip()!r}") from None
        if math.isnan(x) or (math.isinf(x) and key != "radius"):
            raise ParameterError(f"--si {key} must be finite, got {value.strip()!r}")
        out[key] = x
    missing = [n for n in _SI_REQUIRED if n not in out]
    if missing:
        raise ParameterError(f"--si needs {', '.join(missing)} (all of "
                             f"{', '.join(_SI_REQUIRED)}; gravity optional)")
    return out


def planform_flags(args, defaults, also=()):
    """Fill the planform's flags ``defaults`` (name -> default) of a command
    that takes one sheet's planform in ``args``, from ``--si`` or their
    defaults; return the sheet's length (the SI sheet's, else ``--length``,
    which may be None).  ``--si`` cannot be combined with any of the flags,
    ``--length``, nor the further ``(flag, value)`` pairs of ``also`` that
    were given."""
    given = [k for k in defaults if getattr(args, k) is not None]
    if args.si is not None:
        flags = ["--" + k.replace("_", "-") for k in given]
        flags += ["--length"] if args.length is not None else []
        flags += [flag for flag, value in also if value is not None]
        if flags:
            raise ParameterError(f"--si cannot be combined with {', '.join(flags)} (give every "
                                 f"quantity in --si, in SI units)")
        sheet = si_sheet(args.si)
        for k in defaults:
            setattr(args, k, getattr(sheet, k))
        return sheet.length
    for k, v in defaults.items():
        if getattr(args, k) is None:
            setattr(args, k, v)
    return args.length


def si_sheet(text) -> Sheet:
    """The :class:`Sheet` of ``--si`` text; prints what was given and the
    dimensionless parameters it maps to."""
    si = parse_si(text)
    sheet = Sheet.from_si(**si)
    print(f"SI input {', '.join(f'{k}={v:g}' for k, v in si.items())}")
    print(f"SI input -> L/a = {sheet.length:.6g}, b/a = {sheet.tip_width:.6g}, "
          f"a/R = {sheet.curvature:.6g}, h/a = {sheet.thickness:.6g}, "
          f"E/(rho g a) = {sheet.modulus:.6g}")
    return sheet


def si_base_width(args):
    """The base width a in metres of ``--si`` (None without it)."""
    si = getattr(args, "si", None)
    return None if si is None else parse_si(si)["base_width"]


def sheet_from_args(args) -> Sheet:
    """The :class:`Sheet` of the parsed sheet flags (or of ``--si``)."""
    given = {k: getattr(args, k) for k in SHEET_DEFAULTS if getattr(args, k) is not None}
    if getattr(args, "si", None) is not None:
        if given:
            flags = ", ".join("--" + k.replace("_", "-") for k in given)
            raise ParameterError(f"--si cannot be combined with {flags} (give every quantity "
                                 f"in --si, in SI units)")
        return si_sheet(args.si)
    if getattr(args, "planform", None) is not None:
        if "tip_width" in given:
            raise ParameterError("--tip-width cannot be combined with --planform "
                                 "(the planform gives the width)")
        params = {k: v for k, v in {**SHEET_DEFAULTS, **given}.items() if k != "tip_width"}
        return Sheet.from_planform(read_planform_csv(args.planform), **params)
    return Sheet(length=args.length, **{**SHEET_DEFAULTS, **given})


def _header(sheet, args) -> str:
    """The first line printed: every parameter of the sheet and of the mesh."""
    return (f"sheet: {sheet_line(sheet, args.gravity)}; {args.path}, hmax {args.hmax:g}"
            + (f", refine {args.refine}" if args.refine else "")
            + ("" if not args.full_sheet else ", whole sheet"))


def run(args) -> int:
    """Solve, write the files asked for, print the result; 0 if converged, else 1."""
    sheet = sheet_from_args(args)
    for name, suffix in (("json", ".json"), ("vtu", ".vtu"), ("png", ".png")):
        if getattr(args, name):
            check_writable(f"--{name}", getattr(args, name), [suffix])
    if args.path == "both":
        return run_both(args, sheet)
    if args.path not in PATHS:
        raise ParameterError(f"--path must be one of {', '.join(PATHS)}, both; got {args.path!r}")
    if getattr(args, "folds", None) is not None:
        raise ParameterError("--folds is for --path both (the fold lengths against both "
                             "load paths' end states)")
    print(_header(sheet, args), flush=True)
    series = None
    if args.series:
        check_directory("--series", args.series)
        series = Series()
    result = solve(sheet, path=args.path, hmax=args.hmax, layers=args.layers,
                   refine=args.refine, solver=args.solver, symmetric=not args.full_sheet,
                   on_failure="return", progress=not args.quiet, series=series,
                   start=_start(args), coarse_hmax=args.coarse_hmax, gravity=args.gravity,
                   sensitivities=getattr(args, "sensitivities", None) or ())
    if result.sensitivities is not None and getattr(args, "si", None) is not None:
        si = parse_si(args.si)   # the SI values of d's sensitivities too
        result = replace(result, sensitivities=result.sensitivities.with_si(
            si["base_width"], si["density"], si.get("gravity", 9.81)))
    if args.json:
        result.write(args.json)
    if args.vtu:
        result.write(args.vtu)
    if args.png:
        plot_sheet(result, args.png)
    pvd = series.write(args.series, result.path) if series is not None and len(series) else None
    status = "converged" if result.converged else f"NOT converged: {result.message}"
    a = si_base_width(args)
    print(f"tip deflection d/a = {result.deflection:.6f}"
          + ("" if a is None else f" (d = {1e3 * a * result.deflection:.4g} mm)")
          + f"  ({status})")
    if result.converged:
        stable = {True: "stable", False: "unstable", None: "stability unknown"}[result.stable]
        why = f" ({result.mode.reason})" if result.mode is not None else ""
        print(f"  {result.branch}{why}, {stable}; --path both tells whether the sheet is "
              f"bistable")
    print(f"  {result.path}, {result.dofs} dofs{'' if result.symmetric else ' (whole sheet)'}, "
          f"{result.newton_iterations} Newton iterations "
          f"in {result.load_steps} load steps, {result.wall_time_s:.1f} s "
          f"(linear solver {result.linear_solve_s:.1f} s, assembly {result.assembly_s:.1f} s)")
    for f in (args.json, args.vtu, args.png):
        if f:
            print(f"  wrote {f}")
    for snap in result.snaps:
        print(f"  snapped in the {snap.phase} phase at the fold at {snap.load:.6g} of its "
              f"range (a/R {snap.curvature:.6g}, g {snap.gravity:.6g}): d/a "
              f"{snap.fold_deflection:.6f} -> {snap.landing_deflection:.6f}")
    if result.coarse_factorizations:
        print(f"  start {result.start}: {result.factorizations} factorisations on hmax "
              f"{result.hmax:g}, {result.coarse_factorizations} on the coarse mesh"
              + (f" (ran the path on hmax {result.hmax:g}: {result.coarse_fallback})"
                 if result.coarse_fallback else ""))
    if pvd:
        print(f"  wrote {pvd} ({len(series)} steps)")
    if result.sensitivities is not None:
        _print_sensitivities(result.sensitivities)
    return 0 if result.converged else 1


def run_both(args, sheet) -> int:
    """``--path both``: both load paths, whether their end states differ, the fold
    lengths with ``--folds``; 0 if both converged, else 1."""
    if getattr(args, "series", None):
        raise ParameterError("--series is for one load path: run --path curvature-first "
                             "and --path gravity-first, each with its own --series")
    lengths = None
    if args.folds not in (None, "auto"):
        lengths = parse_range(args.folds, "--folds", pair="short:long", example="0.6:2.4")
    print(_header(sheet, args), flush=True)
    states = solve_both(sheet, hmax=args.hmax, folds=args.folds is not None, lengths=lengths,
                        progress=not args.quiet, layers=args.layers, refine=args.refine,
                        solver=args.solver, symmetric=not args.full_sheet, start=_start(args),
                        coarse_hmax=args.coarse_hmax, gravity=args.gravity,
                        sensitivities=getattr(args, "sensitivities", None) or ())
    if getattr(args, "si", None) is not None:   # the SI values of d's sensitivities too
        si = parse_si(args.si)
        states = replace(states, **{
            name: replace(r, sensitivities=r.sensitivities.with_si(
                si["base_width"], si["density"], si.get("gravity", 9.81)))
            for name, r in (("curvature_first", states.curvature_first),
                            ("gravity_first", states.gravity_first))
            if r.sensitivities is not None})
    for line in states.lines(si_base_width(args))[1:]:   # the first: the header, printed
        print(line)
    for r in (states.curvature_first, states.gravity_first):
        if r.sensitivities is not None:
            print(f"  {r.path}:")
            _print_sensitivities(r.sensitivities)
    written = []
    if args.json:
        written += states.write(args.json)
    if args.vtu:
        written += states.write(args.vtu)
    if args.png:
        for r in (states.curvature_first, states.gravity_first):
            written.append(with_path(args.png, r.path))
            plot_sheet(r, written[-1])
    for f in written:
        print(f"  wrote {f}")
    return 0 if states.converged else 1


def _print_sensitivities(sens) -> None:
    print(f"  sensitivities of d/a ({sens.back_substitutions} back-substitutions, "
          f"{sens.factorizations} factorisations, {sens.time_s:.2f} s):")
    si = sens.in_si() if sens.si is not None else None
    for name, v in sens.of("deflection").items():
        line = f"    d(d/a)/d({name}) = {v:+.6g}"
        if si is not None:
            si_name = SI_UNITS[name][0]
            line += (f"   (SI: dd/d{si_name} = {si['values']['deflection'][si_name]:+.6g} "
                     f"{si['units']['deflection'][si_name]})")
        print(line)


def _start(args) -> str:
    """``--start``, by default ``coarse``, or ``path`` with ``--series`` (a
    series of the whole load path on the mesh asked for)."""
    start = getattr(args, "start", None)
    if start is None:
        start = "path" if getattr(args, "series", None) else "coarse"
    return start
