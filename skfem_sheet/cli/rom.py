"""``skfem-sheet rom``: the reduced-order models (see :mod:`skfem_sheet.reduced`).

:func:`register` adds the ``rom`` command with the sub-commands
``persistence``, ``elastica``, ``cantilever``, ``ribbon`` and ``map``; each sets
``run`` (``args -> exit code``).  Bad input raises ``ParameterError`` (a
``ValueError``; the main CLI reports it in one line, exit status 2).  JSON keys
are a contract:

- persistence: ``persistence_length``, ``persistence_length_asymptotic``
- elastica, cantilever: ``deflection``
- ribbon: ``lengths``, ``deflection``, ``converged`` (lists in continuation order)

Examples
--------
>>> import argparse
>>> p = argparse.ArgumentParser(); sub = p.add_subparsers(dest="command")
>>> register(sub)
>>> args = p.parse_args(["rom", "elastica", "--length", "1"])
>>> args.run(args)
elastica: L/a=1 b/a=1 h/a=0.03 E=735 -> d/a = 0.768087 (converged)
0
"""
from __future__ import annotations

import os

import numpy as np

from ..io import write_json
from ..params import ParameterError, Sheet, read_planform_csv
from ..reduced.cantilever import cantilever_deflection
from ..reduced.elastica import elastica
from ..reduced.maps import jump_curve, plot_map, ribbon_map, write_map_csv
from ..reduced.persistence import persistence_length
from ..reduced.ribbon import ribbon_continuation
from .ranges import parse_range
from .solve import SI_HELP, si_sheet

__all__ = ["register"]


def _write_json(path, payload) -> None:
    if path:
        write_json(payload, path)


#: The defaults of the sheet's flags (``None`` in the parser, so that ``--si``
#: can tell which were given).
_DEFAULTS = {"curvature": 0.0, "thickness": 0.03, "modulus": 735.0}


def _sheet(args, length=None) -> Sheet:
    """The sheet of the flags: a trapezoid, the ``--planform`` file's profile,
    or the ``--si`` sheet."""
    if getattr(args, "si", None) is not None:
        given = [k for k in ("length", "tip_width", "curvature", "thickness", "modulus",
                             "planform") if getattr(args, k, None) is not None]
        if given:
            flags = ", ".join("--" + k.replace("_", "-") for k in given)
            raise ParameterError(f"--si cannot be combined with {flags} (give every quantity "
                                 f"in --si, in SI units)")
        sheet = si_sheet(args.si)
        if not hasattr(args, "curvature") and sheet.curvature != 0:
            print(f"  (this model has no clamp curvature: a/R = {sheet.curvature:.6g} is "
                  f"left out)")
            sheet = sheet.replace(curvature=0.0)
        return sheet
    if getattr(args, "curvature", None) is None and getattr(args, "required_curvature", False):
        raise ParameterError("--curvature is required (a/R, the clamp curvature), or --si")
    params = {k: v if getattr(args, k, None) is None else getattr(args, k)
              for k, v in _DEFAULTS.items()}
    if length is None:
        length = args.length
    if getattr(args, "planform", None):
        if args.tip_width is not None:
            raise ParameterError("--tip-width cannot be combined with --planform "
                                 "(the planform gives the width)")
        return Sheet.from_planform(read_planform_csv(args.planform), length=length, **params)
    if length is None:
        raise ParameterError("--length is required (or --planform FILE.csv, or --si)")
    tip = 1.0 if args.tip_width is None else args.tip_width
    return Sheet(length=length, tip_width=tip, **params)


def _label(sheet: Sheet) -> str:
    return (f"L/a={sheet.length:g} b/a={sheet.tip_width:g} a/R={sheet.curvature:g} "
            f"h/a={sheet.thickness:g} E={sheet.modulus:g}")


# -- commands ------------------------------------------------------------------------
def _cmd_persistence(args) -> int:
    sheet = _sheet(args)
    r = persistence_length(sheet)
    _write_json(args.json, {
        "persistence_length": r.persistence_length,
        "persistence_length_asymptotic": r.persistence_length_asymptotic,
        "rectangle_persistence_length": r.rectangle_length, "lhat": r.lhat,
        "delta_hat": r.delta_hat, "reaches_tip": r.reaches_tip, "sheet": sheet.to_dict()})
    print(f"persistence: {_label(sheet)} -> L_p/a = {r.persistence_length:.6g} "
          f"(asymptotic {r.persistence_length_asymptotic:.6g}, rectangle {r.rectangle_length:.6g})")
    return 0


def _cmd_elastica(args) -> int:
    sheet = _sheet(args)
    r = elastica(sheet)
    _write_json(args.json, {"deflection": r.deflection, "converged": r.converged,
                            "sheet": sheet.to_dict()})
    print(f"elastica: L/a={sheet.length:g} b/a={sheet.tip_width:g} h/a={sheet.thickness:g} "
          f"E={sheet.modulus:g} -> d/a = {r.deflection:.6f} "
          f"({'converged' if r.converged else 'NOT converged'})")
    return 0


def _cmd_cantilever(args) -> int:
    sheet = _sheet(args)
    r = cantilever_deflection(sheet, include_curved_part=args.include_curved_part)
    _write_json(args.json, {"deflection": r.deflection, "flat_drop": r.flat_drop,
                            "curved_rise": r.curved_rise,
                            "persistence_length": r.persistence_length,
                            "coefficient": r.coefficient, "sheet": sheet.to_dict()})
    print(f"cantilever: {_label(sheet)} -> d/a = {r.deflection:.6g} "
          f"(L_p/a = {r.persistence_length:.6g}, C = {r.coefficient:.6g})")
    return 0


def _cmd_ribbon(args) -> int:
    lengths = parse_range(args.lengths, "--lengths")
    template = _sheet(args, length=float(lengths[0]))  # a planform is stretched to each L
    br = ribbon_continuation(template, lengths, args.direction,
                             impose_flat=args.impose_flat, n_elements=args.elements)
    _write_json(args.json, {
        "lengths": br.lengths.tolist(), "deflection": br.deflection.tolist(),
        "converged": br.converged.tolist(), "stable": br.stable.tolist(),
        "jumped": br.jumped.tolist(), "jump_lengths": br.jump_lengths.tolist(),
        "direction": br.direction, "impose_flat": bool(args.impose_flat),
        "sheet": {k: v for k, v in template.to_dict().items() if k != "length"}})
    jumps = ", ".join(f"{x:.4f}" for x in br.jump_lengths) or "none"
    print(f"ribbon ({br.direction} L, {len(br.lengths)} lengths "
          f"{br.lengths[0]:g}..{br.lengths[-1]:g}, b/a={template.tip_width:g}, "
          f"a/R={template.curvature:g}): d/a from {br.deflection[0]:.4f} to "
          f"{br.deflection[-1]:.4f}; jumps at L/a = {jumps}; "
          f"{int(br.converged.sum())}/{br.converged.size} converged")
    return 0


def _cmd_map(args) -> int:
    lengths = (parse_range(args.lengths, "--lengths") if args.lengths
               else np.linspace(0.8, 2.2, 50))
    widths = (parse_range(args.tip_widths, "--tip-widths") if args.tip_widths
              else np.linspace(0.0, 1.0, 50))
    if widths.min() < 0 or widths.max() > 1:
        raise ParameterError(f"--tip-widths must be in [0, 1], got {args.tip_widths!r}")
    Sheet(length=float(lengths[0]), curvature=args.curvature, thickness=args.thickness,
          modulus=args.modulus)  # validate up front
    workers = args.workers or min(2, os.cpu_count() or 1)
    rows = ribbon_map(args.curvature, lengths, widths, thickness=args.thickness,
                      modulus=args.modulus, n_elements=args.elements, workers=workers)
    if args.csv:
        write_map_csv(rows, args.csv)
    if args.png:
        plot_map(rows, args.png, title=f"a/R={args.curvature:g}")
    bs, jl = jump_curve(rows, "increasing")
    has = np.isfinite(jl)
    extent = (f"jumps for b/a in [{bs[has].min():g}, {bs[has].max():g}]" if has.any()
              else "no jumps")
    print(f"map: a/R={args.curvature:g}, {lengths.size} lengths x {widths.size} shape "
          f"factors x 2 directions, {sum(not r['converged'] for r in rows)} not converged; "
          f"{extent}" + (f"; csv -> {args.csv}" if args.csv else "")
          + (f"; png -> {args.png}" if args.png else ""))
    return 0


# -- parser --------------------------------------------------------------------------
def _common(parser, length=True, curvature=True, required_curvature=False, planform=False):
    if length:
        parser.add_argument("--length", type=float, default=None,
                            help="L/a" + (" (default with --planform: its last x)"
                                          if planform else "") + " (or --si)")
        parser.add_argument("--si", default=None, metavar="NAME=VALUE,...", help=SI_HELP)
        parser.set_defaults(required_curvature=required_curvature)
    parser.add_argument("--tip-width", type=float, default=None, help="b/a (default 1)")
    if planform:
        parser.add_argument("--planform", default=None, metavar="FILE.csv",
                            help="width profile instead of a trapezoid: CSV with columns "
                                 "x,width (x from 0 to L; L is the last x)")
    if curvature:
        parser.add_argument("--curvature", type=float, default=None,
                            help="a/R" + (" (required, or --si)" if required_curvature
                                          else " (default 0)"))
    parser.add_argument("--thickness", type=float, default=None, help="h/a (default 0.03)")
    parser.add_argument("--modulus", type=float, default=None,
                        help="E/(rho g a) (default 735)")


def register(subparsers) -> None:
    """Add the ``rom`` command (reduced-order models) and its sub-commands.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        From ``parser.add_subparsers(...)``.
    """
    rom = subparsers.add_parser(
        "rom", help="reduced-order models (persistence length, elastica, cantilever, ribbon)",
        description="Reduced-order models of the curved sheet.")
    sub = rom.add_subparsers(dest="rom_command", metavar="MODEL")
    sub.required = True

    p = sub.add_parser("persistence", help="gravity-free persistence length L_p")
    _common(p, required_curvature=True)
    p.add_argument("--json", help="write results to this JSON file")
    p.set_defaults(run=_cmd_persistence)

    p = sub.add_parser("elastica", help="heavy elastica with varying width")
    _common(p, curvature=False, planform=True)
    p.add_argument("--json", help="write results to this JSON file")
    p.set_defaults(run=_cmd_elastica)

    p = sub.add_parser("cantilever", help="Euler-Bernoulli cantilever beyond L_p")
    _common(p)
    p.add_argument("--include-curved-part", action="store_true",
                   help="also count the rise W_0(L_p) of the curved part")
    p.add_argument("--json", help="write results to this JSON file")
    p.set_defaults(run=_cmd_cantilever)

    p = sub.add_parser("ribbon", help="ribbon model, continuation in L")
    _common(p, length=False, planform=True)
    p.add_argument("--lengths", required=True, help="start:stop:step of L/a")
    p.add_argument("--direction", choices=("increasing", "decreasing"), default="increasing")
    p.add_argument("--impose-flat", action="store_true", help="impose c == 0 (heavy elastica)")
    p.add_argument("--elements", type=int, default=24, help="finite elements (default 24)")
    p.add_argument("--json", help="write results to this JSON file")
    p.set_defaults(run=_cmd_ribbon)

    p = sub.add_parser("map", help="Fig. 6 deflection map over (L/a, b/a)")
    p.add_argument("--curvature", type=float, required=True, help="a/R")
    p.add_argument("--lengths", help="start:stop:step of L/a (default 50 in 0.8..2.2)")
    p.add_argument("--tip-widths", help="start:stop:step of b/a (default 50 in 0..1)")
    p.add_argument("--thickness", type=float, default=0.03, help="h/a (default 0.03)")
    p.add_argument("--modulus", type=float, default=735.0, help="E/(rho g a) (default 735)")
    p.add_argument("--elements", type=int, default=24, help="finite elements (default 24)")
    p.add_argument("--workers", type=int, default=0, help="processes (default: up to 2)")
    p.add_argument("--csv", help="write the tidy table here")
    p.add_argument("--png", help="draw the colour map here")
    p.set_defaults(run=_cmd_map)
