"""``skfem-sheet calibrate``: fit the modulus (or other parameters) to observed deflections.

Give the sheet (``--tip-width``, ``--curvature``, ``--thickness``, and
``--modulus`` as the starting value) and the measurements, as ``--length L
--deflection D`` pairs (repeat both, in order; ``--uncertainty S`` for each
or for none) or a CSV file with columns ``length,deflection`` (optionally
``tip_width,curvature,uncertainty,path``).  Least squares with the solves'
sensitivities as the Jacobian; the fitted values with their standard errors
are printed and written to ``--json`` (each fitted parameter by name, and
``deflection``: the model's d at the fit).  Measurements that cannot
determine the free parameters, or that lie across a snap, are refused with
a message (exit code 2).
"""
from __future__ import annotations

import math

from ..calibration import FIT_PARAMETERS, Measurement, calibrate, read_measurements
from ..io import check_writable, write_json
from ..params import DEFAULT_HMAX, ParameterError, Sheet
from .solve import SHEET_DEFAULTS, solver_help

__all__ = ["register", "run", "measurements_from_args"]


def register(subparsers) -> None:
    """Add the ``calibrate`` command."""
    p = subparsers.add_parser("calibrate", help="fit the modulus (or others) to measured "
                              "tip deflections", description=__doc__.split("\n\n")[1]
                              .replace("``", ""))
    p.add_argument("--length", type=float, action="append", default=None,
                   help="L/a of a measured sheet (repeat, one per --deflection)")
    p.add_argument("--deflection", type=float, action="append", default=None,
                   help="measured tip deflection d/a, positive downward (repeat)")
    p.add_argument("--uncertainty", type=float, action="append", default=None,
                   help="standard deviation of each --deflection (repeat; all or none)")
    p.add_argument("--csv", default=None, metavar="FILE",
                   help="measurements from a CSV file (columns length,deflection and "
                        "optionally tip_width,curvature,uncertainty,path)")
    p.add_argument("--tip-width", type=float, default=SHEET_DEFAULTS["tip_width"],
                   help="b/a (default 1)")
    p.add_argument("--curvature", type=float, default=SHEET_DEFAULTS["curvature"],
                   help="a/R (default 0; the starting value if free)")
    p.add_argument("--thickness", type=float, default=SHEET_DEFAULTS["thickness"],
                   help="h/a (default 0.03; the starting value if free)")
    p.add_argument("--modulus", type=float, default=SHEET_DEFAULTS["modulus"],
                   help="E/(rho g a): the starting value if free (default 735)")
    p.add_argument("--gravity", type=float, default=1.0,
                   help="load factor, a fraction of the sheet's own weight (default 1; the "
                        "starting value if free)")
    p.add_argument("--free", default="modulus",
                   help=f"comma list of the fitted parameters from {', '.join(FIT_PARAMETERS)} "
                        "(default modulus)")
    p.add_argument("--path", default="curvature-first",
                   help="load path of the solves (curvature-first or gravity-first)")
    p.add_argument("--hmax", type=float, default=DEFAULT_HMAX,
                   help=f"mesh size (default {DEFAULT_HMAX:g}, the paper's; 0.1 for a quick "
                        f"look)")
    p.add_argument("--solver", default="auto", help=solver_help())
    p.add_argument("--max-evaluations", type=int, default=20,
                   help="most model evaluations (each one solve per measurement; default 20)")
    p.add_argument("--json", default=None, help="write the fit here")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=run)


def measurements_from_args(args) -> tuple:
    """The measurements of ``--length``/``--deflection``/``--uncertainty`` or ``--csv``."""
    lengths, deflections = args.length or [], args.deflection or []
    if args.csv is not None:
        if lengths or deflections or args.uncertainty:
            raise ParameterError("--csv cannot be combined with --length, --deflection or "
                                 "--uncertainty (put them in the file)")
        return read_measurements(args.csv)
    if not deflections:
        raise ParameterError("calibrate needs measurements: --length L --deflection D (repeat "
                             "for several) or --csv FILE")
    if len(lengths) != len(deflections):
        raise ParameterError(f"--length and --deflection must come in pairs, got "
                             f"{len(lengths)} lengths and {len(deflections)} deflections")
    unc = args.uncertainty or []
    if unc and len(unc) != len(deflections):
        raise ParameterError(f"--uncertainty must be given once per --deflection or not at "
                             f"all, got {len(unc)} for {len(deflections)}")
    return tuple(Measurement(deflection=d, length=L, uncertainty=unc[i] if unc else None)
                 for i, (L, d) in enumerate(zip(lengths, deflections)))


def run(args) -> int:
    """Fit, print the fitted values and the residuals, write ``--json``; 0 on a fit."""
    if args.json:
        check_writable("--json", args.json, [".json"])
    ms = measurements_from_args(args)
    length = next((m.length for m in ms if m.length is not None), None)
    if length is None:
        raise ParameterError("every measurement needs its length (--length, or a length "
                             "column in --csv)")
    sheet = Sheet(length=length, tip_width=args.tip_width, curvature=args.curvature,
                  thickness=args.thickness, modulus=args.modulus)
    fit = calibrate(sheet, ms, free=args.free, path=args.path, hmax=args.hmax,
                    gravity=args.gravity, solver=args.solver,
                    max_evaluations=args.max_evaluations, progress=not args.quiet)
    for name, v, se in zip(fit.parameters, fit.values, fit.standard_errors):
        err = "" if math.isnan(se) else f" +- {se:.4g} (standard error, noise from {fit.noise})"
        print(f"{name} = {v:.6g}{err}")
    if fit.noise == "undetermined":
        print("  (as many measurements as free parameters: an exact fit, no standard error; "
              "give --uncertainty for one)")
    for m, md, r in zip(fit.measurements, fit.model_deflections, fit.residuals):
        print(f"  L/a {m.length:g}: measured d/a {m.deflection:.6f}, model {md:.6f}, "
              f"residual {r:+.2e}")
    print(f"  {fit.solves} solves ({fit.evaluations} model evaluations) at hmax {fit.hmax:g}, "
          f"{fit.wall_time_s:.1f} s; {fit.message}")
    if args.json:
        write_json(fit.summary(), args.json)
        print(f"  wrote {args.json}")
    return 0 if fit.converged else 1
