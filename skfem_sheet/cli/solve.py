"""``skfem-sheet solve``: one sheet along one load path (also the code path of ``demo``)."""
from __future__ import annotations

from ..io import check_writable
from ..params import Sheet
from ..plot import plot_sheet
from ..solve import solve

__all__ = ["register", "run", "add_sheet_args", "add_solve_args"]


def add_sheet_args(p, length=None) -> None:
    """The sheet's parameters (``--length`` required unless ``length`` is given)."""
    p.add_argument("--length", type=float, required=length is None, default=length,
                   help="L/a, sheet length in base widths")
    p.add_argument("--tip-width", type=float, default=1.0, help="b/a (1 rectangle, 0 triangle)")
    p.add_argument("--curvature", type=float, default=0.0, help="a/R, clamp curvature")
    p.add_argument("--thickness", type=float, default=0.03, help="h/a (default 0.03)")
    p.add_argument("--modulus", type=float, default=735.0, help="E/(rho g a) (default 735)")


def add_solve_args(p, hmax=0.03) -> None:
    """The solve's options and output files."""
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


def register(subparsers) -> None:
    """Add the ``solve`` command."""
    p = subparsers.add_parser("solve", help="solve one sheet along one load path")
    add_sheet_args(p)
    add_solve_args(p)
    p.set_defaults(run=run)


def run(args) -> int:
    """Solve, write the files asked for, print the result; 0 if converged, else 1."""
    sheet = Sheet(length=args.length, tip_width=args.tip_width, curvature=args.curvature,
                  thickness=args.thickness, modulus=args.modulus)
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
        plot_sheet(result, args.png)
    status = "converged" if result.converged else f"NOT converged: {result.message}"
    print(f"tip deflection d/a = {result.deflection:.6f}  ({status})")
    print(f"  {result.path}, {result.dofs} dofs, {result.newton_iterations} Newton iterations "
          f"in {result.load_steps} load steps, {result.wall_time_s:.1f} s "
          f"(linear solver {result.linear_solve_s:.1f} s, assembly {result.assembly_s:.1f} s)")
    for f in (args.json, args.vtu, args.png):
        if f:
            print(f"  wrote {f}")
    return 0 if result.converged else 1
