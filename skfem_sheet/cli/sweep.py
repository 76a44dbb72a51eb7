"""``skfem-sheet sweep``: a grid of sheets solved in parallel into one resumable table.

See :mod:`skfem_sheet.studies.sweep` for the table and the journal.

Examples
--------
>>> import argparse
>>> p = argparse.ArgumentParser(); sub = p.add_subparsers(dest="command")
>>> register(sub)
>>> args = p.parse_args(["sweep", "--lengths", "1,2", "--table", "x.csv"])
>>> args.lengths, args.paths, args.workers, args.refine, args.symmetric, args.start
('1,2', 'curvature-first', None, '0', 'yes', 'coarse')
"""
from __future__ import annotations

from ..io import check_writable
from ..params import ParameterError
from ..studies.sweep import check_point, grid, run_sweep
from .ranges import parse_values
from .solve import solver_help

__all__ = ["register", "run"]

_PATHS = ("curvature-first", "gravity-first")
_SYMMETRIC = {"yes": [True], "no": [False], "both": [True, False]}
_STARTS = {"coarse": ["coarse"], "path": ["path"], "both": ["coarse", "path"]}


def register(subparsers) -> None:
    """Add the ``sweep`` command."""
    p = subparsers.add_parser(
        "sweep", help="solve a grid of sheets in parallel into one table (resumable)",
        description="Solve the cartesian product of the given values (each 'a:b:step', b "
                    "included, or 'x,y,...') on local processes or a Dask cluster.  Results "
                    "go to --table (.csv or .parquet) and its journal <table>.journal.jsonl; "
                    "running the same command again resumes (finished points are kept).")
    p.add_argument("--lengths", required=True, help="L/a values, e.g. 0.5:1.5:0.25 or 1,1.3")
    p.add_argument("--tip-widths", default="1", help="b/a values (default 1)")
    p.add_argument("--curvatures", default="0", help="a/R values (default 0)")
    p.add_argument("--thicknesses", default="0.03", help="h/a values (default 0.03)")
    p.add_argument("--moduli", default="735", help="E/(rho g a) values (default 735)")
    p.add_argument("--paths", default="curvature-first",
                   help="both, or a comma list of curvature-first, gravity-first")
    p.add_argument("--hmax", default="0.03", help="mesh sizes (default 0.03)")
    p.add_argument("--layers", default=None, help="element layers through the thickness")
    p.add_argument("--refine", default="0",
                   help="nested refinements of each mesh, e.g. 0,1 (0-4, default 0)")
    p.add_argument("--symmetric", default="yes", choices=tuple(_SYMMETRIC),
                   help="solve the symmetric half (yes, default), the whole sheet (no), or both")
    p.add_argument("--start", default="coarse", choices=tuple(_STARTS),
                   help="coarse (default): each load path on a coarse mesh, finished on "
                        "--hmax; path: the whole load path on --hmax; or both (see solve)")
    p.add_argument("--coarse-hmax", default=None,
                   help="mesh sizes of the coarse start's path, e.g. 0.1,0.2 (default: the "
                        "start's own, 0.1 up to --hmax 0.05)")
    p.add_argument("--gravities", default="1",
                   help="gravity as a fraction of the sheet's own weight, e.g. 0.5,1 "
                        "(default 1)")
    p.add_argument("--solver", default="auto", help=solver_help(plural=True))
    p.add_argument("--table", required=True, help="results table, .csv or .parquet")
    p.add_argument("--workers", type=int, default=None,
                   help="local worker processes (default: number of CPUs; 1: no pool)")
    p.add_argument("--scheduler", default=None,
                   help="Dask scheduler address tcp://host:port (needs skfem_sheet[cluster])")
    p.add_argument("--retry-failed", action="store_true",
                   help="compute again the points stored as not converged")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=run)


def run(args) -> int:
    """Check every point up front, run the sweep, print a summary; 0 (Ctrl-C: the
    main entry point says what was kept, code 130)."""
    if args.workers is not None and args.workers < 1:
        raise ParameterError(f"--workers must be an integer >= 1, got {args.workers}")
    paths = _PATHS if args.paths.strip() == "both" else \
        tuple(s.strip() for s in args.paths.split(","))
    for q in paths:
        if q not in _PATHS:
            raise ParameterError(f"--paths must be 'both' or a comma list of "
                                 f"{', '.join(_PATHS)}, got {q!r}")
    solvers = [s.strip() for s in args.solver.split(",")]
    points = grid(length=parse_values(args.lengths, "--lengths"),
                  tip_width=parse_values(args.tip_widths, "--tip-widths"),
                  curvature=parse_values(args.curvatures, "--curvatures"),
                  thickness=parse_values(args.thicknesses, "--thicknesses"),
                  modulus=parse_values(args.moduli, "--moduli"),
                  path=list(paths), hmax=parse_values(args.hmax, "--hmax"),
                  layers=[None] if args.layers is None else parse_values(args.layers, "--layers",
                                                                           int),
                  solver=solvers, refine=parse_values(args.refine, "--refine", int),
                  symmetric=_SYMMETRIC[args.symmetric], start=_STARTS[args.start],
                  coarse_hmax=([None] if args.coarse_hmax is None
                               else parse_values(args.coarse_hmax, "--coarse-hmax")),
                  gravity=parse_values(args.gravities, "--gravities"))
    for p in points:
        check_point(p)
    check_writable("--table", args.table, [".csv", ".parquet"])
    df = run_sweep(points, table=args.table, workers=args.workers, scheduler=args.scheduler,
                   progress=not args.quiet, retry_failed=args.retry_failed)
    info = df.attrs["sweep"]
    rows = df.drop_duplicates("key")
    n_conv = int(rows.converged.sum())
    print(f"sweep: {info['points']} points, {n_conv} converged, {info['points'] - n_conv} "
          f"failed ({info['new']} computed now, {info['cached']} from earlier runs) "
          f"-> {info['table']}")
    pairs = rows[rows.bistable.notna()]
    if len(pairs):
        n_bi = int(pairs.drop_duplicates(["length", "tip_width", "curvature", "thickness",
                                          "modulus", "hmax"]).bistable.astype(bool).sum())
        print(f"  both paths: {n_bi} bistable sheets (two distinct stable states; the "
              f"'bistable' column)")
    for _, r in rows[~rows.converged].head(5).iterrows():
        print(f"  failed: L/a={r.length:g} b/a={r.tip_width:g} a/R={r.curvature:g} "
              f"{r.path} hmax={r.hmax:g}: {r.message}")
    return 0
