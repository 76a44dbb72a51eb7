"""Command line: ``python -m skfem_sheet`` (also installed as ``skfem-sheet``).

Commands
--------
``solve``  one sheet along one load path; ``--json`` / ``--vtu`` / ``--png``
``demo``   a default sheet (the paper's bistable rectangle, aloft branch):
           prints d, writes a PNG picture and a VTU file
``rom``    reduced-order models (persistence length, cantilever, elastica,
           ribbon; see ``skfem_sheet.reduced``)

Bad arguments give a one-line message naming the parameter and the allowed
range, and exit code 2 (no traceback).  A solve that does not reach full load
prints why and exits with code 1 (its JSON says ``"converged": false``).
"""
from __future__ import annotations

import argparse
import sys

__all__ = ["main", "build_parser"]


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit code 2
        self.exit(2, f"{self.prog}: error: {message}\n")


def _add_sheet_args(p, length=None):
    p.add_argument("--length", type=float, required=length is None, default=length,
                   help="L/a, sheet length in base widths")
    p.add_argument("--tip-width", type=float, default=1.0, help="b/a (1 rectangle, 0 triangle)")
    p.add_argument("--curvature", type=float, default=0.0, help="a/R, clamp curvature")
    p.add_argument("--thickness", type=float, default=0.03, help="h/a (default 0.03)")
    p.add_argument("--modulus", type=float, default=735.0, help="E/(rho g a) (default 735)")


def _add_solve_args(p, hmax=0.03):
    p.add_argument("--path", default="curvature-first",
                   help="load path: curvature-first (aloft branch) or gravity-first (drooped)")
    p.add_argument("--hmax", type=float, default=hmax, help=f"mesh size (default {hmax})")
    p.add_argument("--layers", type=int, default=None, help="element layers through the thickness")
    p.add_argument("--refine", type=int, default=0,
                   help="nested refinement: halve every edge this many times (0-4, default 0)")
    p.add_argument("--solver", default="auto", help="linear solver: auto, pardiso, superlu")
    p.add_argument("--json", default=None, help="write a JSON summary here")
    p.add_argument("--vtu", default=None, help="write the deformed sheet (VTU, ParaView) here")
    p.add_argument("--png", default=None, help="write a picture of the deformed sheet here")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def build_parser():
    parser = _Parser(prog="skfem-sheet", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    p = sub.add_parser("solve", help="solve one sheet along one load path")
    _add_sheet_args(p)
    _add_solve_args(p)
    p.set_defaults(func=_solve)
    p = sub.add_parser("demo", help="solve a default sheet, print d, write PNG and VTU")
    _add_sheet_args(p, length=1.3)
    p.set_defaults(curvature=2.5)
    _add_solve_args(p, hmax=0.04)
    p.set_defaults(func=_demo, png="demo.png", vtu="demo.vtu", json=None)
    for module, hook in _SUBCOMMANDS:
        import importlib

        try:
            mod = importlib.import_module(f"skfem_sheet.{module}")
        except ModuleNotFoundError as err:  # a command whose module is not there yet
            if err.name != f"skfem_sheet.{module}":
                raise
            continue
        getattr(mod, hook)(sub)
    return parser


#: Commands defined in their own modules: (module, function adding the subparser).
_SUBCOMMANDS = (("reduced.cli", "add_rom_subparser"), ("sweep", "add_sweep_subparser"),
                ("bistability", "add_bistability_subparser"), ("foldmap", "add_fold_map_subparser"),
                ("figures", "add_figure_subparser"))


def _sheet(args):
    from .params import Sheet

    return Sheet(length=args.length, tip_width=args.tip_width, curvature=args.curvature,
                 thickness=args.thickness, modulus=args.modulus)


def _run(args):
    from .io import check_writable
    from .solve import solve

    sheet = _sheet(args)
    for name, suffix in (("json", ".json"), ("vtu", ".vtu"), ("png", ".png")):
        if getattr(args, name):
            check_writable(f"--{name}", getattr(args, name), [suffix])
    result = solve(sheet, path=args.path, hmax=args.hmax, layers=args.layers,
                   refine=args.refine, solver=args.solver, on_failure="return",
                   progress=not args.quiet)
    if args.json:
        result.write(args.json)
    if args.vtu:
        result.write(args.vtu)
    if args.png:
        from .plot import plot_sheet

        plot_sheet(result, args.png)
    return result


def _print_result(result, files):
    status = "converged" if result.converged else f"NOT converged: {result.message}"
    print(f"tip deflection d/a = {result.deflection:.6f}  ({status})")
    print(f"  {result.path}, {result.dofs} dofs, {result.newton_iterations} Newton iterations "
          f"in {result.load_steps} load steps, {result.wall_time_s:.1f} s "
          f"(linear solver {result.linear_solve_s:.1f} s, assembly {result.assembly_s:.1f} s)")
    for f in files:
        if f:
            print(f"  wrote {f}")


def _solve(args):
    result = _run(args)
    _print_result(result, [args.json, args.vtu, args.png])
    return 0 if result.converged else 1


def _demo(args):
    result = _run(args)
    _print_result(result, [args.json, args.vtu, args.png])
    return 0 if result.converged else 1


def main(argv=None) -> int:
    """Entry point; returns the exit code."""
    from .params import ParameterError

    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except ParameterError as err:
        print(f"{parser.prog} {args.command}: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"{parser.prog} {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
