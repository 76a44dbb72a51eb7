"""The package's layers, read from its imports (``ast``; nothing is imported).

The layers of ``docs/architecture.md``: a module may import modules of its own
layer and of the layers below, never above.  What a module uses from another
is public there: no ``_private`` name (nor a private module outside its own
package) is imported across modules.  Argument parsing lives in
``skfem_sheet/cli/`` only.

Every import counts, also those inside functions and ``importlib.import_module``
calls with a literal name; doctests are read for private names.
"""
from __future__ import annotations

import ast
import doctest
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "skfem_sheet"

#: The layout, lowest first: module path (a file, or a folder ending in "/" for
#: every module in it) -> layer.  A new module needs a line here and in the table
#: of docs/architecture.md (test_the_documented_table_is_this_one checks both agree).
LAYERS = {
    "version.py": 0, "params.py": 0, "mesh.py": 0, "io.py": 0,   # parameters, mesh, files
    "engine/": 1,             # the continuation engine: generic, imports only params
    "discretisation.py": 2,   # TaylorHoodSpace: bases, dof layout, split/join, dof sets
    "kernels.py": 3,          # material kernels (pure numpy)
    "assembly.py": 4,         # Assembler: sparsity pattern, buffers, its own threads
    "problem.py": 5,          # SheetProblem: residual, tangent, energy, with_length
    "build.py": 5,            # BuildChain: the meshes, spaces, assemblers a solve or study keeps
    "linalg/": 6,             # linear solvers, given a SaddlePointLayout: one module a back-end
    "newton.py": 7,           # the sheet on the engine's Newton and pseudo-transient, Stats, timed
    "analyses/": 8,           # stability, observables, transfer between meshes, mid-surface,
                              # sensitivities of a solved state and of a fold
    "reduced/": 9,            # reduced-order models
    "sheet_engine.py": 9,     # the sheet as an engine problem: Factorization, SheetLoadProblem
    "continuation.py": 10,    # load paths (follow_path): continuation in the loads, snaps
    "sheet_shape.py": 10,     # the sheet as an engine problem in (L, b, a/R), the remesh rule
    "result.py": 11,          # Result, Result.to_record, StartRecord, SolveError
    "starts.py": 11,          # the start strategies (PathStart, CoarseStart)
    "solve.py": 11,           # solve: the facade
    "bistability/": 12,       # branches in L and a/R, fold lengths, the S-curve, fold_curve
    "foldcurve/": 12,         # fold curves in (L, b) and (L, a/R), the cusp (on the engine)
    "paths.py": 12,           # one equilibrium along a polyline in (L, b, a/R), its jumps
    "calibration.py": 12,     # located folds' sensitivities, calibration to measured deflections
    "states.py": 12,          # solve_both: both load paths, whether their states differ
    "switch/": 12,            # switching forces and barriers: the S-curve in the tip force
    "studies/": 13,           # runner, sweep, fold map
    "figures/": 14,           # one module per figure, cached tables
    "plot.py": 14,            # drawing a solved sheet
    "__init__.py": 14,        # the package's facade (Sheet, solve, ..., sweep, figure), lazy
    "cli/": 15,               # all argparse: one module per command
    "__main__.py": 15,        # python -m skfem_sheet
}


# -- reading the package ------------------------------------------------------------------
def _relpath(path: Path) -> str:
    return path.relative_to(PACKAGE).as_posix()


def _module_name(rel: str) -> str:
    """``studies/sweep.py`` -> ``skfem_sheet.studies.sweep`` (``__init__.py``: the package)."""
    parts = ["skfem_sheet", *rel[:-3].split("/")]
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _module_file(name: str):
    """The file of a module of the package (relative path), or None if there is none."""
    parts = name.split(".")[1:]
    if not parts:
        return "__init__.py"
    base = PACKAGE.joinpath(*parts)
    if base.with_suffix(".py").is_file():
        return _relpath(base.with_suffix(".py"))
    if (base / "__init__.py").is_file():
        return _relpath(base / "__init__.py")
    return None


def layer_of(rel: str):
    """The layer of a module path, or None if the table does not place it."""
    if rel in LAYERS:
        return LAYERS[rel]
    parts = rel.split("/")
    for i in range(len(parts) - 1, 0, -1):
        folder = "/".join(parts[:i]) + "/"
        if folder in LAYERS:
            return LAYERS[folder]
    return None


def _is_private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _package_of(module: str, rel: str) -> str:
    return module if rel.endswith("__init__.py") else module.rpartition(".")[0]


def imports(source: str, rel: str):
    """``(line, target module, imported name or None, what)`` of every import of
    the package's modules in ``source`` (the text of module ``rel``), and
    ``(line, "argparse", None, what)`` for argparse."""
    module = _module_name(rel)
    package = _package_of(module, rel)
    tree = ast.parse(source)
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name == "argparse" or alias.name.startswith("argparse."):
                    out.append((node.lineno, "argparse", None, f"import {alias.name}"))
                elif alias.name == "skfem_sheet" or alias.name.startswith("skfem_sheet."):
                    out.append((node.lineno, alias.name, None, f"import {alias.name}"))
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)]
                base = ".".join(base + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            if base == "argparse" or base.startswith("argparse."):
                out.append((node.lineno, "argparse", None, f"from {base} import ..."))
                continue
            if not (base == "skfem_sheet" or base.startswith("skfem_sheet.")):
                continue
            for alias in node.names:
                sub = f"{base}.{alias.name}"
                if _module_file(sub) is not None:  # a module imported from its package
                    out.append((node.lineno, sub, None, f"from {base} import {alias.name}"))
                else:
                    out.append((node.lineno, base, alias.name, f"from {base} import {alias.name}"))
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
              and node.func.attr == "import_module" and node.args
              and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)
              and node.args[0].value.startswith("skfem_sheet")):
            name = node.args[0].value
            out.append((node.lineno, name, None, f"import_module({name!r})"))
    return out


def _dotted(node):
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if isinstance(node, ast.Name):
        return ".".join([node.id, *reversed(parts)])
    return None


def private_attributes(source: str, rel: str):
    """``(line, module, attribute)`` where ``module._attribute`` is used on a
    module of the package bound by an import (``from . import sweep as s; s._x``)."""
    module = _module_name(rel)
    package = _package_of(module, rel)
    tree = ast.parse(source)
    bound = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("skfem_sheet"):
                    if alias.asname:
                        bound[alias.asname] = alias.name
                    else:
                        bound["skfem_sheet"] = "skfem_sheet"
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = ".".join(base[:len(base) - (node.level - 1)]
                                + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            for alias in node.names:
                sub = f"{base}.{alias.name}"
                if base.startswith("skfem_sheet") and _module_file(sub) is not None:
                    bound[alias.asname or alias.name] = sub
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and _is_private(node.attr):
            chain = _dotted(node.value)
            if chain is None:
                continue
            head, *rest = chain.split(".")
            if head not in bound:
                continue
            target = ".".join([bound[head], *rest])
            if _module_file(target) is not None and target != module:
                out.append((node.lineno, target, node.attr))
    return out


def _docstring_sources(source: str):
    """The code of the doctest examples of every docstring of ``source``."""
    tree = ast.parse(source)
    parser = doctest.DocTestParser()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            doc = ast.get_docstring(node, clean=True)
            if doc and ">>>" in doc:
                for example in parser.get_examples(doc):
                    yield example.source


def modules():
    return sorted(_relpath(p) for p in PACKAGE.rglob("*.py"))


def _violations_private(rel: str, source: str):
    module = _module_name(rel)
    bad = []
    for line, target, name, what in imports(source, rel):
        if target == "argparse" or target == module:
            continue
        if name is not None and _is_private(name):
            bad.append(f"{rel}:{line}: {what} (a private name of another module)")
        private = [i for i, part in enumerate(target.split(".")) if _is_private(part)]
        if private:
            owner = ".".join(target.split(".")[:private[0]])  # the private module's package
            if not (module == owner or module.startswith(owner + ".")):
                bad.append(f"{rel}:{line}: {what} (a private module outside its package)")
    for line, target, attr in private_attributes(source, rel):
        bad.append(f"{rel}:{line}: {target}.{attr} (a private name of another module)")
    return bad


def _violations_up(rel: str, source: str):
    mine = layer_of(rel)
    bad = []
    for line, target, _, what in imports(source, rel):
        if target == "argparse":
            continue
        file = _module_file(target)
        theirs = layer_of(file) if file is not None else None
        if file is None:
            bad.append(f"{rel}:{line}: {what}: no such module in the package")
        elif mine is not None and theirs is not None and theirs > mine:
            bad.append(f"{rel}:{line}: {what}: layer {mine} imports layer {theirs} ({file})")
    return bad


SOURCES = {rel: (PACKAGE / rel).read_text() for rel in modules()}


# -- the rules ----------------------------------------------------------------------------
def test_every_module_has_a_layer():
    missing = [rel for rel in SOURCES if layer_of(rel) is None]
    assert not missing, ("modules not in the layer table of tests/test_architecture.py "
                         f"(and docs/architecture.md): {missing}")


def test_imports_only_point_down():
    bad = [v for rel, src in SOURCES.items() for v in _violations_up(rel, src)]
    assert not bad, "imports pointing up a layer:\n" + "\n".join(bad)


def test_no_private_name_is_imported_from_another_module():
    bad = [v for rel, src in SOURCES.items() for v in _violations_private(rel, src)]
    for rel, src in SOURCES.items():  # doctests show the public API too
        for code in _docstring_sources(src):
            try:
                bad += [f"{rel} (doctest): {v.split(': ', 1)[1]}"
                        for v in _violations_private(rel, code)]
            except SyntaxError:
                continue
    assert not bad, "private names used across modules:\n" + "\n".join(bad)


def test_argparse_only_in_cli():
    bad = [f"{rel}:{line}: {what}" for rel, src in SOURCES.items()
           if not rel.startswith("cli/")
           for line, target, _, what in imports(src, rel) if target == "argparse"]
    assert not bad, "argparse outside skfem_sheet/cli/:\n" + "\n".join(bad)


def _documented_layers():
    """The layer table of docs/architecture.md: ``{module path: layer}``."""
    text = (PACKAGE.parent / "docs" / "architecture.md").read_text()
    tables = [block for block in text.split("\n\n") if block.startswith("| layer | module")]
    assert len(tables) == 1, f"docs/architecture.md has {len(tables)} layer tables, not one"
    layers = {}
    for row in tables[0].splitlines()[2:]:
        cells = [c.strip() for c in row.strip("|").split("|")]
        for name in cells[1].replace("(", ",").replace(")", ",").split(","):
            name = name.replace("and", "").strip().strip("`").strip()
            if name.endswith(".py") or name.endswith("/"):
                layers[name] = int(cells[0])
    return layers


def test_the_documented_table_is_this_one():
    assert _documented_layers() == LAYERS


def test_the_package_names_come_from_its_layer_or_below():
    """``skfem_sheet.X`` is imported on first use from the module named in
    ``__init__._LAZY`` (a dict of strings or ``(module, name)`` pairs, which
    the import reader does not see): none of them may sit above the facade's
    own layer."""
    tree = ast.parse((PACKAGE / "__init__.py").read_text())
    lazy = next(node.value for node in ast.walk(tree) if isinstance(node, ast.Assign)
                and any(isinstance(t, ast.Name) and t.id == "_LAZY" for t in node.targets))
    targets = [v.elts[0].value if isinstance(v, ast.Tuple) else v.value for v in lazy.values]
    assert targets and all(t.startswith("skfem_sheet.") for t in targets)
    own = layer_of("__init__.py")
    above = {t: layer_of(_module_file(t)) for t in targets
             if layer_of(_module_file(t)) > own}
    assert not above, above


# -- the checker itself -------------------------------------------------------------------
@pytest.mark.parametrize("rel, code, rule", [
    ("solve.py", "def f():\n    from .cli import main\n", "up"),          # deferred, still up
    ("params.py", "import skfem_sheet.studies.sweep\n", "up"),
    ("linalg/factory.py", "import importlib\nimportlib.import_module('skfem_sheet.cli')\n", "up"),
    ("studies/foldmap.py", "from . import sweep as s\ns._execute()\n", "private"),
    ("studies/foldmap.py", "from .sweep import _Job\n", "private"),
    ("cli/rom.py", "from ..reduced._common import as_sheet\n", "private"),
    ("bistability/lengths.py", "import argparse\n", "argparse"),
])
def test_the_checker_finds_each_kind_of_violation(rel, code, rule):
    up, private = _violations_up(rel, code), _violations_private(rel, code)
    argparse_ = [t for _, t, _, _ in imports(code, rel) if t == "argparse"]
    assert {"up": up, "private": private, "argparse": argparse_}[rule]
    assert not [v for k, v in (("up", up), ("private", private), ("argparse", argparse_))
                if k != rule and v]


@pytest.mark.parametrize("rel, code", [
    ("cli/solve.py", "from ..solve import solve\nfrom . import ranges\n"),   # down, same layer
    ("reduced/ribbon.py", "from skfem_sheet.reduced._common import as_sheet\n"),  # own package
    ("studies/sweep.py", "from ..version import __version__\n"),             # dunder
    ("cli/__init__.py", "import argparse\nfrom . import solve\n"),           # argparse in cli/
])
def test_the_checker_allows_what_the_rules_allow(rel, code):
    assert not _violations_up(rel, code) and not _violations_private(rel, code)


# -- the load path's knobs -------------------------------------------------------------------
def _module_constants(rel):
    """Module-level UPPER_CASE names assigned in ``rel`` (constants and knobs)."""
    tree = ast.parse((PACKAGE / rel).read_text())
    names = set()
    for node in tree.body:
        targets = (node.targets if isinstance(node, ast.Assign)
                   else [node.target] if isinstance(node, ast.AnnAssign) else [])
        for t in targets:
            if isinstance(t, ast.Name) and t.id.lstrip("_").isupper():
                names.add(t.id)
    return names


def test_the_load_path_has_at_most_twelve_knobs():
    """The module constants of solve.py, continuation.py and starts.py (the
    start strategies, split off solve.py) and the fields of StepOptions: the
    load path's knobs (30 under the move-size guard; each remaining one a
    numerical tolerance documented where it is defined)."""
    from dataclasses import fields

    from skfem_sheet.continuation import StepOptions

    knobs = (_module_constants("solve.py") | _module_constants("continuation.py")
             | _module_constants("starts.py") | {f.name for f in fields(StepOptions)})
    assert len(knobs) <= 12, sorted(knobs)
