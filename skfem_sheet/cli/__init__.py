"""Command line: ``python -m skfem_sheet`` (also installed as ``skfem-sheet``).

Commands: ``python -m skfem_sheet --help`` lists them (``solve``, ``demo``, ``rom``,
``sweep``, ``bistability``, ``fold-curve``, ``fold-map``, ``figure``, ``calibrate``,
``switch``).

All argument parsing of the package lives here, one module per command; each
exposes ``register(subparsers)``, which adds the command's parser and sets
``run`` (``args -> exit code``).  Ranges and lists of values are parsed by
:mod:`skfem_sheet.cli.ranges`.

Bad arguments give a one-line message naming the parameter and the allowed
range, and exit code 2 (no traceback).  A solve that does not reach full load
prints why and exits with code 1 (its JSON says ``"converged": false``).
Ctrl-C exits with code 130 within seconds (a factorisation under way
finishes first); a study (``sweep``, ``fold-map``, ``figure``) abandons
the points in flight and says how many it finished and kept, and where.
"""
from __future__ import annotations

import argparse
import sys

from ..version import __version__

__all__ = ["main", "build_parser", "COMMANDS"]

#: The command modules, in the order of ``--help``.  They are imported when the
#: parser is built (``cli.COMMANDS`` too), so that ``--version`` needs no numerics.
COMMAND_NAMES = ("solve", "demo", "rom", "sweep", "bistability", "fold_curve", "fold_map",
                 "figure", "calibrate", "switch")


def _commands():
    from . import (
        bistability,
        calibrate,
        demo,
        figure,
        fold_curve,
        fold_map,
        rom,
        solve,
        sweep,
        switch,
    )

    modules = dict(solve=solve, demo=demo, rom=rom, sweep=sweep, bistability=bistability,
                   fold_curve=fold_curve, fold_map=fold_map, figure=figure, calibrate=calibrate,
                   switch=switch)
    return tuple(modules[name] for name in COMMAND_NAMES)


def __getattr__(name):
    if name == "COMMANDS":
        return _commands()
    raise AttributeError(f"module 'skfem_sheet.cli' has no attribute {name!r}")


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit code 2
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    """The ``skfem-sheet`` parser with every command of :data:`COMMANDS`."""
    parser = _Parser(prog="skfem-sheet", description=__doc__.split("\n\n")[0].replace("``", ""))
    parser.add_argument("--version", action="version", version=f"skfem-sheet {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for command in _commands():
        command.register(sub)
    return parser


def main(argv=None) -> int:
    """Entry point; returns the exit code."""
    if list(sys.argv[1:] if argv is None else argv) == ["--version"]:
        print(f"skfem-sheet {__version__}")   # without building the parser (no numerics)
        return 0
    from ..params import ParameterError

    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.run(args) or 0)
    except ParameterError as err:
        print(f"{parser.prog} {args.command}: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as err:   # a study's says what it kept (StudyInterrupted)
        print(f"{parser.prog} {args.command}: {err or 'interrupted'}", file=sys.stderr)
        return 130
