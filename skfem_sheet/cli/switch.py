"""``skfem-sheet switch``: how hard is a bistable sheet to switch?

The switching forces (the tip force, total, positive upward, that snaps the
aloft state down and the drooped state up), the energy barriers between the
two states and the saddle between them, from the force-deflection curve in
the tip force (see the module skfem_sheet.switch).  The sheet is given in its
dimensionless parameters or in SI units (``--si``, then the forces are also
printed in mN and the barriers in microjoules).  ``--json`` writes the
summary (keys ``force_down``, ``force_up``, ``barrier_down``, ``barrier_up``,
``saddle_deflection``, ``bistable``, ...), ``--curve`` the curve as CSV.

Examples
--------
>>> import argparse
>>> p = argparse.ArgumentParser(); sub = p.add_subparsers(dest="command")
>>> register(sub)
>>> a = p.parse_args(["switch", "--length", "1.3", "--curvature", "2.5", "--hmax", "0.1"])
>>> a.hmax, a.curve_hmax, a.max_force
(0.1, None, 2.0)
"""
from __future__ import annotations

from ..io import check_writable
from ..result import SolveError
from ..switch import CURVE_HMAX, SIScale, switching
from .solve import add_sheet_args, parse_si, sheet_from_args, solver_help

__all__ = ["register", "run"]


def register(subparsers) -> None:
    """Add the ``switch`` command."""
    p = subparsers.add_parser(
        "switch", help="switching forces and energy barriers of a bistable sheet",
        description=__doc__.split("\n\n")[1].replace("``", ""))
    add_sheet_args(p)
    p.add_argument("--hmax", type=float, default=0.03, help="mesh size (default 0.03)")
    p.add_argument("--curve-hmax", type=float, default=None,
                   help=f"trace the curve on this mesh (default: --hmax from 0.1 up, else "
                        f"{CURVE_HMAX:g}; its folds, saddle and other state are then "
                        f"located again on --hmax)")
    p.add_argument("--layers", type=int, default=None, help="element layers through the "
                                                             "thickness")
    p.add_argument("--solver", default="auto", help=solver_help())
    p.add_argument("--full-sheet", action="store_true",
                   help="the whole sheet (admits asymmetric states and branch points) instead "
                        "of the mirror-symmetric half")
    p.add_argument("--max-force", type=float, default=2.0,
                   help="the largest |F| traced, in units of the sheet's weight (default 2)")
    p.add_argument("--json", default=None, help="write the summary here (JSON)")
    p.add_argument("--curve", default=None, metavar="FILE.csv",
                   help="write the force-deflection curve here (CSV)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=run)


def run(args) -> int:
    """Analyse the sheet, print the result, write the files asked for; 0, or 1
    if the sheet could not be solved."""
    sheet = sheet_from_args(args)
    if args.json:
        check_writable("--json", args.json, [".json"])
    if args.curve:
        check_writable("--curve", args.curve, [".csv"])
    si = None
    if getattr(args, "si", None) is not None:
        given = parse_si(args.si)
        si = SIScale(given["base_width"], given["density"], given.get("gravity", 9.81))
    try:
        result = switching(sheet, hmax=args.hmax, curve_hmax=args.curve_hmax,
                           layers=args.layers, solver=args.solver,
                           symmetric=not args.full_sheet, max_force=args.max_force, si=si,
                           progress=not args.quiet)
    except SolveError as err:
        print(f"switch: {err}")
        return 1
    print(result)
    if args.json:
        result.write(args.json)
        print(f"  wrote {args.json}")
    if args.curve:
        result.curve.write(args.curve)
        print(f"  wrote {args.curve}")
    return 0
