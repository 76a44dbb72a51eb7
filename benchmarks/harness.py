"""The shared parts of the benchmark scripts (``import common`` in a script of
``benchmarks/``: Python puts the script's folder on the path).

- :func:`parser`: the one argument parser of every script (description and
  ``--help`` text from the script's docstring), and :data:`RESULTS`, the folder of
  the recorded outputs;

- analysis of a mesh sequence: :func:`richardson` (three-point Richardson
  extrapolation, constant or varying refinement ratio), :func:`power_law_fit`
  (least-squares ``d = d_inf + C h^p`` through any number of points),
  :func:`loglog_slope` (observed order from ``log|d - d_inf|`` against ``log h``),
  :func:`local_orders` (the order of every three consecutive meshes) and
  :func:`nested_family` (the meshes of a nested refinement study);
- isolated solves: :func:`run_isolated` runs one ``solve`` in a fresh Python
  process (so that its peak memory, read from ``/proc/self/status`` VmHWM inside
  that process, belongs to that solve alone) and returns a JSON-ready record;
- :class:`RunStore`: a JSON file rewritten after every finished run, so an
  interrupted benchmark keeps its finished runs and a rerun skips them;
- sampled, journalled solves (:func:`random_sheets`, :func:`run_journalled`,
  :func:`solve_or_crash`) of ``stress.py`` and ``snap_sample.py``; machine
  information and formatting (:func:`machine_info`, :func:`fmt`).

Only the public API is used: ``Sheet``, ``solve`` and the ``Result`` fields,
``skfem_sheet.linalg.available_solvers`` and the signature of ``solve`` (to
detect options such as ``symmetric``).  Run this file as
``python common.py --child SPEC OUT`` to do one solve (that is what
:func:`run_isolated` does).
"""
from __future__ import annotations

import argparse
import inspect
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
import traceback
from collections import Counter

import numpy as np
from tqdm.auto import tqdm

import skfem_sheet
from skfem_sheet import Sheet, solve
from skfem_sheet.continuation import PATHS
from skfem_sheet.studies.runner import read_journal

__all__ = ["richardson", "power_law_fit", "loglog_slope", "analyse_sequence", "local_orders",
           "nested_family",
           "run_isolated", "RunStore", "code_version", "available_backends", "solve_supports",
           "solve_default",
           "estimate_unknowns", "parse_family", "fmt", "machine_info", "add_run_options",
           "open_store", "warn_if_busy", "interrupted", "random_sheets", "both_paths", "solve_key",
           "add_start_option", "start_options", "coarse_fields", "compare_journals",
           "solve_or_crash", "read_jsonl", "add_shard_option", "parse_shard",
           "run_journalled", "parser", "peak_rss_bytes", "RESULTS"]

GB = 1024.0 ** 3

#: The recorded outputs, one folder per suite (accuracy, speed, robustness, acceptance).
RESULTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "results")


def parser(doc, **kwargs):
    """The argument parser of a benchmark script: its description is the first
    paragraph of the script's docstring, and ``--help`` prints the whole docstring
    after the options (how to run it, what it measures).

    >>> parser("Title line.").description
    'Title line.'
    """
    kwargs.setdefault("formatter_class", argparse.RawDescriptionHelpFormatter)
    paragraphs = (doc or "").strip().split("\n\n")
    return argparse.ArgumentParser(description=paragraphs[0],
                                   epilog="\n\n".join(paragraphs[1:]) or None, **kwargs)


# ---------------------------------------------------------------------------
# Analysis of a mesh sequence
# ---------------------------------------------------------------------------
def _ratio_function(h1, h2, h3, p):
    """``(h1^p - h2^p) / (h2^p - h3^p)`` (its limit at ``p -> 0`` for tiny p)."""
    if abs(p) < 1e-12:
        return math.log(h1 / h2) / math.log(h2 / h3)
    return (h1 ** p - h2 ** p) / (h2 ** p - h3 ** p)


def richardson(h, d, max_order=20.0):
    """Richardson extrapolation from three meshes: ``d(h) = d_inf + C h^p`` exactly.

    Parameters
    ----------
    h : sequence of 3 floats
        Mesh sizes, coarse to fine (strictly decreasing).
    d : sequence of 3 floats
        The computed quantity on those meshes.
    max_order : float
        Largest order searched for when the refinement ratio is not constant.

    Returns
    -------
    d_inf, p, C : float
        Extrapolated value, observed order and error constant.  For a constant
        ratio ``r = h1/h2 = h2/h3`` the order is the three-point formula
        ``p = log((d1 - d2)/(d2 - d3)) / log r``; otherwise ``p`` solves
        ``(d1 - d2)/(d2 - d3) = (h1^p - h2^p)/(h2^p - h3^p)``.

    Raises
    ------
    ValueError
        If the data are not in a converging regime: non-monotone
        (differences of opposite signs), differences not shrinking (p <= 0),
        or an order above ``max_order``.  No order is made up in that case.

    Examples
    --------
    >>> d_inf, p, C = richardson([0.4, 0.2, 0.1], [1 + 0.16, 1 + 0.04, 1 + 0.01])
    >>> round(d_inf, 12), round(p, 12), round(C, 12)
    (1.0, 2.0, 1.0)
    """
    h = np.asarray(h, dtype=float)
    d = np.asarray(d, dtype=float)
    if h.shape != (3,) or d.shape != (3,):
        raise ValueError("richardson needs exactly three meshes")
    h1, h2, h3 = h
    if not h1 > h2 > h3 > 0:
        raise ValueError(f"mesh sizes must decrease strictly and stay positive, got {h.tolist()}")
    d12, d23 = d[0] - d[1], d[1] - d[2]
    if d12 == 0 or d23 == 0 or d12 * d23 < 0:
        raise ValueError(f"non-monotone sequence (differences {d12:+.3e}, {d23:+.3e}): "
                         "no asymptotic order")
    q = d12 / d23
    r12, r23 = h1 / h2, h2 / h3
    if abs(r12 / r23 - 1) < 1e-9:
        p = math.log(q) / math.log(r12)
        if p <= 0:
            raise ValueError(f"differences do not shrink (ratio {q:.3g}): no convergence order")
        if p > max_order:
            raise ValueError(f"order {p:.3g} above {max_order:g}: not in the asymptotic range")
    else:
        from scipy.optimize import brentq

        lo, hi = 1e-9, float(max_order)
        g_lo = _ratio_function(h1, h2, h3, lo) - q
        g_hi = _ratio_function(h1, h2, h3, hi) - q
        if g_lo >= 0:
            raise ValueError(f"differences do not shrink fast enough (ratio {q:.3g}): "
                             "no positive order")
        if g_hi < 0:
            raise ValueError(f"order above {max_order:g} (ratio {q:.3g}): "
                             "not in the asymptotic range")
        p = brentq(lambda s: _ratio_function(h1, h2, h3, s) - q, lo, hi, xtol=1e-14, rtol=1e-14)
    C = d23 / (h2 ** p - h3 ** p)
    d_inf = d[2] - C * h3 ** p
    return float(d_inf), float(p), float(C)


def power_law_fit(h, d, orders=(0.1, 10.0)):
    """Least-squares fit of ``d = d_inf + C h^p`` to any number (>= 3) of meshes.

    For fixed ``p`` the model is linear in ``(d_inf, C)``; ``p`` minimises the
    residual over ``orders`` (a fine grid, then a bounded 1D search).

    Returns
    -------
    d_inf, p, C, rms : float
        ``rms`` is the root-mean-square residual (0 for three points).

    Examples
    --------
    >>> h = [0.2, 0.1, 0.05, 0.025]
    >>> d_inf, p, C, rms = power_law_fit(h, [2 - 3 * x ** 1.5 for x in h])
    >>> round(d_inf, 9), round(p, 6), round(C, 6)
    (2.0, 1.5, -3.0)
    """
    h = np.asarray(h, dtype=float)
    d = np.asarray(d, dtype=float)
    if h.size < 3 or h.size != d.size:
        raise ValueError("power_law_fit needs at least three (h, d) pairs")

    p, (d_inf, C), ssq = _profiled_order(
        h, d, lambda p: np.column_stack([np.ones_like(h), h ** p]), orders, 400)
    return float(d_inf), p, float(C), math.sqrt(ssq / h.size)


def _profiled_order(h, d, design, orders, n_grid):
    """Least squares for a model that is linear in its coefficients once the
    order ``p`` is fixed (``design(p)`` is its matrix): ``p`` minimises the
    residual over ``orders``, on a grid and then by a bounded 1D search.
    Returns ``(p, coefficients, residual sum of squares)``."""
    from scipy.optimize import minimize_scalar

    def solve_linear(p):
        M = design(p)
        coef, *_ = np.linalg.lstsq(M, d, rcond=None)
        return coef, float(np.sum((M @ coef - d) ** 2))

    grid = np.linspace(orders[0], orders[1], n_grid)
    res = [solve_linear(p)[1] for p in grid]
    k = int(np.argmin(res))
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    opt = minimize_scalar(lambda p: solve_linear(p)[1], bounds=(lo, hi), method="bounded",
                          options=dict(xatol=1e-12))
    p = float(opt.x) if opt.fun <= res[k] else float(grid[k])
    coef, rss = solve_linear(p)
    return p, coef, rss


def two_term_design(h, p):
    """Columns ``1, h^p, h^(p+1)`` of the two-term model: ``two_term_design(h, p)
    @ [d_inf, A, B]`` is ``d_inf + A h^p + B h^(p+1)`` at the sizes ``h``."""
    h = np.asarray(h, dtype=float)
    return np.column_stack([np.ones_like(h), h ** p, h ** (p + 1)])


def two_term_fit(h, d, orders=(0.5, 5.0)):
    """Least-squares fit of ``d = d_inf + A h^p + B h^(p+1)`` (the leading
    error term and the next one) to five or more meshes, with standard errors.

    Where the two error terms have opposite signs and are comparable, the
    error changes sign or turns, and three-mesh Richardson sees no order at
    all; with several nested families (whose points lie on one curve ``d(h)``
    if the expansion holds) the leading order is still measurable.  For fixed
    ``p`` the model is linear in ``(d_inf, A, B)``; ``p`` minimises the
    residual over ``orders``.  The standard errors are the Gauss-Newton ones,
    ``sigma^2 (J^T J)^-1`` with ``sigma^2 = rss / (n - 4)``.

    Returns
    -------
    dict
        ``order``, ``order_se``, ``extrapolated``, ``extrapolated_se``, ``A``,
        ``B``, ``rms`` (root-mean-square residual) and ``residuals``.

    Examples
    --------
    >>> h = [0.16, 0.08, 0.04, 0.12, 0.06, 0.03]
    >>> f = two_term_fit(h, [-0.0768 + 0.07 * x ** 2 - 0.5 * x ** 3 for x in h])
    >>> round(f["order"], 6), round(f["extrapolated"], 9), round(f["B"], 6)
    (2.0, -0.0768, -0.5)
    """
    h = np.asarray(h, dtype=float)
    d = np.asarray(d, dtype=float)
    if h.size < 5 or h.size != d.size:
        raise ValueError("two_term_fit needs at least five (h, d) pairs (four unknowns)")

    def design(p):
        return two_term_design(h, p)

    p, (d_inf, A, B), rss = _profiled_order(h, d, design, orders, 451)
    # Jacobian of the model in (d_inf, A, B, p)
    lh = np.log(h)
    J = np.column_stack([design(p), A * h ** p * lh + B * h ** (p + 1) * lh])
    dof = h.size - 4
    se = [math.nan] * 4
    if dof > 0:
        with np.errstate(all="ignore"):
            cov = np.linalg.pinv(J.T @ J) * rss / dof
        se = np.sqrt(np.abs(np.diag(cov)))
    return dict(order=p, order_se=float(se[3]), extrapolated=float(d_inf),
                extrapolated_se=float(se[0]), A=float(A), B=float(B),
                rms=math.sqrt(rss / h.size), residuals=(design(p) @ [d_inf, A, B] - d).tolist())


def loglog_slope(h, err):
    """Least-squares slope of ``log|err|`` against ``log h`` (the observed order).

    Returns
    -------
    slope, intercept : float
        ``|err| ~ exp(intercept) h^slope``.

    Raises
    ------
    ValueError
        If fewer than two points or an error is exactly zero (no logarithm).

    Examples
    --------
    >>> s, c = loglog_slope([0.1, 0.05, 0.025], [0.02, 0.005, 0.00125])
    >>> round(s, 12)
    2.0
    """
    h = np.asarray(h, dtype=float)
    e = np.abs(np.asarray(err, dtype=float))
    if h.size < 2 or h.size != e.size:
        raise ValueError("loglog_slope needs at least two (h, err) pairs")
    if np.any(e == 0):
        raise ValueError("an error is exactly zero: no log-log fit through it")
    slope, intercept = np.polyfit(np.log(h), np.log(e), 1)
    return float(slope), float(intercept)


def analyse_sequence(h, d):
    """Observed order and extrapolated value of a mesh sequence (coarse to fine).

    Richardson extrapolation on the last three meshes gives ``d_inf``; the
    observed order is the log-log least-squares slope of ``|d_k - d_inf|``
    against ``h_k`` over the last three meshes (``observed_order``, equal to the
    Richardson order) and over all of them (``observed_order_all``).  With
    four or more meshes a least-squares power law through all of them is
    reported too.  Non-monotone data give ``None`` for the order and the
    extrapolated value, plus a warning; errors are then relative to the finest
    mesh.

    Returns
    -------
    dict
        ``extrapolated``, ``observed_order``, ``observed_order_all``,
        ``richardson_C``, ``power_law`` (dict or None), ``errors`` (relative,
        signed, per mesh), ``error_reference`` (``"extrapolated"`` or
        ``"finest mesh"``), ``warnings`` (list of str).

    Examples
    --------
    >>> a = analyse_sequence([0.4, 0.2, 0.1], [1.16, 1.04, 1.01])
    >>> round(a["observed_order"], 9), round(a["extrapolated"], 12), a["warnings"]
    (2.0, 1.0, [])
    """
    h = [float(x) for x in h]
    d = [float(x) for x in d]
    out = dict(extrapolated=None, observed_order=None, observed_order_all=None,
               richardson_C=None, power_law=None, errors=None,
               error_reference="finest mesh", warnings=[])
    if len(h) < 3:
        out["warnings"].append(f"only {len(h)} converged meshes: need 3 for an order")
        if d:
            out["errors"] = [x / d[-1] - 1 for x in d]
        return out
    if any(h[k] <= h[k + 1] for k in range(len(h) - 1)):
        raise ValueError("mesh sizes must be sorted coarse to fine")
    diffs = np.diff(d)
    if len(d) > 3 and not (np.all(diffs > 0) or np.all(diffs < 0)):
        out["warnings"].append("non-monotone over all meshes (differences "
                               + ", ".join(f"{x:+.2e}" for x in diffs)
                               + "): the all-mesh order is not meaningful")
    try:
        d_inf, p, C = richardson(h[-3:], d[-3:])
    except ValueError as err:
        out["warnings"].append(f"Richardson on the last three meshes: {err}")
        out["errors"] = [x / d[-1] - 1 for x in d]
        return out
    out.update(extrapolated=d_inf, richardson_C=C, error_reference="extrapolated")
    out["errors"] = [x / d_inf - 1 for x in d]
    e = [x - d_inf for x in d]
    out["observed_order"] = loglog_slope(h[-3:], e[-3:])[0]
    if len(h) > 3:
        if all(x != 0 for x in e):
            out["observed_order_all"] = loglog_slope(h, e)[0]
        d_all, p_all, C_all, rms = power_law_fit(h, d)
        out["power_law"] = dict(extrapolated=d_all, order=p_all, C=C_all, rms=rms)
    if not 0.5 <= p <= 6:
        out["warnings"].append(f"Richardson order {p:.2f} is implausible for P2 elements: "
                               "the meshes are probably not in the asymptotic range")
    return out


def local_orders(h, d):
    """Richardson order of every three consecutive meshes (coarse to fine).

    The order of the triple ``k, k+1, k+2`` is that of :func:`richardson`
    (``log((d_k - d_k+1) / (d_k+1 - d_k+2)) / log r`` for a constant ratio
    ``r``); ``None`` where the triple is not in a converging regime
    (non-monotone, differences not shrinking).  Orders that settle as the mesh
    is refined say that the sequence is in its asymptotic range.

    Returns
    -------
    list of (float or None), length ``len(h) - 2``

    Examples
    --------
    >>> h = [0.4, 0.2, 0.1, 0.05]
    >>> [round(p, 9) for p in local_orders(h, [1 + x ** 2 for x in h])]
    [2.0, 2.0]
    >>> local_orders([0.4, 0.2, 0.1], [1.0, 1.1, 1.05])
    [None]
    """
    out = []
    for k in range(len(h) - 2):
        try:
            out.append(richardson(h[k:k + 3], d[k:k + 3])[1])
        except ValueError:   # not converging on this triple: no order to report
            out.append(None)
    return out


def nested_family(base_hmax, base_layers, refinements):
    """The meshes of a nested family: ``refine = 0 .. refinements`` of one base mesh.

    Refinement ``k`` halves every edge of the base mesh ``k`` times in all
    three directions (``solve(..., hmax=base_hmax, layers=base_layers,
    refine=k)``): edge size ``base_hmax / 2**k``, ``base_layers * 2**k`` layers.

    Returns
    -------
    list of (h, layers, refine)
        ``h`` is the effective mesh size ``base_hmax / 2**k`` (the abscissa of
        the convergence analysis; the refinement ratio is exactly 2).

    Examples
    --------
    >>> nested_family(0.16, 2, 2)
    [(0.16, 2, 0), (0.08, 4, 1), (0.04, 8, 2)]
    """
    if not (isinstance(refinements, int) and refinements >= 0):
        raise ValueError(f"refinements must be a non-negative integer, got {refinements!r}")
    if not (isinstance(base_layers, int) and base_layers >= 1):
        raise ValueError(f"base layers must be a positive integer, got {base_layers!r}")
    if not base_hmax > 0:
        raise ValueError(f"base hmax must be positive, got {base_hmax!r}")
    return [(base_hmax / 2 ** k, base_layers * 2 ** k, k) for k in range(refinements + 1)]


# ---------------------------------------------------------------------------
# Solves in fresh processes
# ---------------------------------------------------------------------------
def solve_supports(name):
    """True if :func:`skfem_sheet.solve` takes the keyword ``name``.

    Examples
    --------
    >>> solve_supports("hmax"), solve_supports("no_such_option")
    (True, False)
    """
    from skfem_sheet import solve

    return name in inspect.signature(solve).parameters


def available_backends():
    """Linear-solver back-ends usable here (never ``"auto"``), best first.

    Examples
    --------
    >>> "superlu" in available_backends()
    True
    """
    from skfem_sheet.linalg import available_solvers

    names = [s for s in available_solvers() if s != "auto"]
    order = {"pardiso": 0, "pyamg": 1, "superlu": 2}
    return sorted(names, key=lambda s: order.get(s, 1))


def solve_default(name):
    """Default value of the keyword ``name`` of :func:`skfem_sheet.solve` (None if absent).

    Examples
    --------
    >>> solve_default("path"), solve_default("no_such_option")
    ('curvature-first', None)
    """
    from skfem_sheet import solve

    p = inspect.signature(solve).parameters.get(name)
    return None if p is None or p.default is inspect.Parameter.empty else p.default


def estimate_unknowns(sheet_kw, hmax, layers=None, symmetric=None, refine=0):
    """Estimated number of unknowns of a solve, or None if the estimator is gone.

    ``symmetric=None`` means the solver's default; ``refine`` the nested
    refinements of the mesh (``solve(..., refine=)``).  Uses
    ``skfem_sheet.mesh.estimate_dofs`` (not public API: only to skip runs that
    are too big, so a missing or changed helper just disables the check).
    """
    try:
        from skfem_sheet import Sheet
        from skfem_sheet.mesh import estimate_dofs
    except ImportError:
        return None
    if symmetric is None:
        symmetric = bool(solve_default("symmetric"))
    kw = {}
    if "half" in inspect.signature(estimate_dofs).parameters:
        kw["half"] = symmetric
    elif symmetric:
        return None   # an estimator that does not know the half mesh: no estimate
    if refine:
        if "refine" not in inspect.signature(estimate_dofs).parameters:
            return None   # an estimator that does not know refinement: no estimate
        kw["refine"] = refine
    return int(estimate_dofs(Sheet(**sheet_kw), hmax, layers, **kw))


def code_version():
    """Short hash of the installed skfem_sheet sources (``*.py`` under the package).

    Stored with every run: runs made with other sources are not reused.
    """
    import hashlib

    root = os.path.dirname(os.path.abspath(skfem_sheet.__file__))
    digest = hashlib.sha1()
    for dirpath, dirnames, filenames in os.walk(root):
        dirnames[:] = sorted(d for d in dirnames if d != "__pycache__")
        for name in sorted(filenames):
            if name.endswith(".py"):
                full = os.path.join(dirpath, name)
                digest.update(os.path.relpath(full, root).encode())
                with open(full, "rb") as f:
                    digest.update(f.read())
    return digest.hexdigest()[:12]


def spec_key(spec):
    """Canonical string of a run specification (the RunStore key)."""
    return json.dumps(spec, sort_keys=True)


def peak_rss_bytes():
    """High-water mark of this process's resident memory, in bytes."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024
    except OSError:  # not Linux: fall back to getrusage
        pass
    import resource

    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak if sys.platform == "darwin" else peak * 1024


def _child(spec_json, out_path):
    """Body of the child process: one solve, its record written to ``out_path``."""
    spec = json.loads(spec_json)
    t_start = time.perf_counter()
    rec = dict(spec=spec, code=code_version())
    try:
        from skfem_sheet import Sheet, solve

        kw = dict(path=spec["path"], hmax=spec["hmax"], layers=spec.get("layers"),
                  solver=spec.get("solver", "auto"), on_failure="return",
                  progress=bool(spec.get("progress", False)))
        for opt in ("quadrature_order", "symmetric", "refine"):
            if spec.get(opt) is not None:
                kw[opt] = spec[opt]
        rss0 = peak_rss_bytes()
        t0 = time.perf_counter()
        r = solve(Sheet(**spec["sheet"]), **kw)
        t_call = time.perf_counter() - t0
    except Exception as err:  # noqa: BLE001 - recorded as a crash of this run, with traceback
        import traceback

        rec.update(status="crash", error=f"{type(err).__name__}: {err}",
                   traceback=traceback.format_exc(),
                   process_s=time.perf_counter() - t_start,
                   peak_rss_gb=peak_rss_bytes() / GB)
    else:
        wall = float(r.wall_time_s)
        lin = float(r.linear_solve_s)
        rec.update(
            status="converged" if r.converged else "failed",
            deflection=float(r.deflection), converged=bool(r.converged),
            message=r.message, dofs=int(r.dofs), layers=int(r.layers), solver=r.solver,
            newton_iterations=int(r.newton_iterations),
            factorizations=int(r.factorizations), load_steps=int(r.load_steps),
            rejected_steps=int(r.rejected_steps),
            wall_time_s=wall, assembly_s=float(r.assembly_s), linear_solve_s=lin,
            call_s=t_call, process_s=time.perf_counter() - t_start,
            assembly_share=float(r.assembly_s) / wall if wall > 0 else None,
            linear_share=lin / wall if wall > 0 else None,
            outside_linear_share=(wall - lin) / wall if wall > 0 else None,
            peak_rss_gb=peak_rss_bytes() / GB, rss_before_solve_gb=rss0 / GB,
            kappa_reached=float(r.kappa), gravity_reached=float(r.gravity),
            volume_change=float(r.volume_change),
            stable=getattr(r, "stable", None), branch=getattr(r, "branch", None),
            snaps=[s.to_json() for s in r.snaps],
            symmetric=getattr(r, "symmetric", spec.get("symmetric")))
    tmp = out_path + ".tmp"
    with open(tmp, "w") as f:
        json.dump(rec, f, default=float)
    os.replace(tmp, out_path)


def run_isolated(spec, timeout=None, threads=None, verbose=False):
    """Run one solve in a fresh Python process and return its record.

    Parameters
    ----------
    spec : dict
        ``sheet`` (keyword arguments of ``Sheet``), ``path``, ``hmax`` and
        optionally ``layers``, ``solver``, ``quadrature_order``, ``symmetric``,
        ``refine``.
    timeout : float, optional
        Seconds after which the child is killed (status ``"timeout"``).
    threads : int, optional
        Sets MKL/OpenMP/OpenBLAS thread counts in the child.
    verbose : bool
        Let the child's progress bar and messages through to stderr.

    Returns
    -------
    dict
        ``status`` is ``"converged"``, ``"failed"`` (clean non-convergence),
        ``"crash"`` (exception or abnormal exit) or ``"timeout"``; the
        ``Result`` fields, ``peak_rss_gb`` (VmHWM of the child), the shares of
        the wall time, and ``spec``.
    """
    env = dict(os.environ)
    pkg_root = os.path.dirname(os.path.dirname(os.path.abspath(skfem_sheet.__file__)))
    env["PYTHONPATH"] = os.pathsep.join(x for x in (pkg_root, env.get("PYTHONPATH")) if x)
    env.setdefault("MPLBACKEND", "Agg")
    if threads:
        for var in ("MKL_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
            env[var] = str(threads)
    child_spec = dict(spec, progress=bool(verbose))
    fd, out = tempfile.mkstemp(prefix="skfem_sheet_bench_", suffix=".json")
    os.close(fd)
    os.unlink(out)
    t0 = time.perf_counter()
    try:
        proc = subprocess.run(
            [sys.executable, os.path.abspath(__file__), "--child", json.dumps(child_spec), out],
            env=env, timeout=timeout, stdout=subprocess.DEVNULL,
            stderr=None if verbose else subprocess.PIPE, text=True)
    except subprocess.TimeoutExpired:
        if os.path.exists(out):
            os.unlink(out)
        return dict(spec=spec, code=code_version(), status="timeout",
                    process_s=time.perf_counter() - t0, error=f"killed after {timeout:g} s")
    if os.path.exists(out):
        with open(out) as f:
            rec = json.load(f)
        os.unlink(out)
        rec["spec"] = spec
        return rec
    tail = (proc.stderr or "").strip().splitlines()[-5:]
    return dict(spec=spec, code=code_version(), status="crash",
                process_s=time.perf_counter() - t0,
                error=f"child exited with code {proc.returncode} without a result"
                      + (": " + " | ".join(tail) if tail else ""))


# ---------------------------------------------------------------------------
# Incremental JSON output
# ---------------------------------------------------------------------------
class RunStore:
    """Runs kept in a JSON file that is rewritten (atomically) after every run.

    ``store.get(spec)`` returns a finished run, or None if there is none, with
    ``force``, with ``retry`` for a run that did not converge, and for a run made
    with other skfem_sheet sources (see :func:`code_version`) unless
    ``reuse_stale``.  ``store.add(record)`` records one and saves,
    ``store.save(**extra)`` writes the analysis fields next to ``"runs"``.
    """

    def __init__(self, path, benchmark, force=False, retry=False, reuse_stale=False):
        self.path = path
        self.force = force
        self.retry = retry
        self.reuse_stale = reuse_stale
        self.code = code_version()
        self.doc = dict(benchmark=benchmark, runs=[])
        if path and os.path.exists(path):
            with open(path) as f:
                old = json.load(f)
            if old.get("benchmark") not in (None, benchmark):
                raise SystemExit(f"{path} holds a {old.get('benchmark')!r} benchmark, "
                                 f"not {benchmark!r}: choose another --json file")
            self.doc["runs"] = old.get("runs", [])
            if "machine" in old:   # where the recorded runs ran, until new ones run
                self.doc["machine"] = old["machine"]
        self._by_key = {spec_key(r["spec"]): r for r in self.doc["runs"]}

    def get(self, spec):
        if self.force:
            return None
        rec = self._by_key.get(spec_key(spec))
        if rec is None:
            return None
        if self.retry and rec["status"] != "converged":
            return None
        if not self.reuse_stale and rec.get("code") != self.code:
            return None
        return rec

    def stale(self):
        """Recorded runs made with other skfem_sheet sources than the current ones."""
        return [r for r in self.doc["runs"] if r.get("code") != self.code]

    def add(self, rec):
        k = spec_key(rec["spec"])
        self.doc["runs"] = [r for r in self.doc["runs"] if spec_key(r["spec"]) != k] + [rec]
        self._by_key[k] = rec
        self.save()

    def save(self, **extra):
        self.doc.update(extra)
        if not self.path:
            return
        tmp = self.path + ".tmp"
        with open(tmp, "w") as f:
            json.dump(self.doc, f, indent=1, default=float)
        os.replace(tmp, self.path)


# ---------------------------------------------------------------------------
# Random samples of sheets solved into a JSON-lines journal (stress, snap_sample)
# ---------------------------------------------------------------------------
#: The keyword arguments of ``Sheet`` a sample point holds.
SHEET_FIELDS = ("length", "tip_width", "curvature", "thickness", "modulus")


def random_sheets(n, seed, thickness=0.03, modulus=735.0):
    """``n`` seeded random sheets (dicts of ``Sheet`` arguments).

    L/a uniform in [0.2, 3], b/a in [0, 1], a/R in [0, 6], drawn in that
    order; then ``thickness`` and ``modulus``, each a value or a range
    ``(lo, hi)`` drawn uniformly after them (so a sample's first three
    columns depend on ``n`` and ``seed`` only).

    Examples
    --------
    >>> a, b = random_sheets(3, 1), random_sheets(3, 1, thickness=(0.02, 0.045))
    >>> [p["length"] for p in a] == [p["length"] for p in b], a[0]["thickness"]
    (True, 0.03)
    """
    rng = np.random.default_rng(seed)
    cols = [rng.uniform(0.2, 3.0, n), rng.uniform(0, 1, n), rng.uniform(0, 6, n)]
    for v in (thickness, modulus):
        cols.append(rng.uniform(v[0], v[1], n) if isinstance(v, tuple) else np.full(n, v))
    return [dict(zip(SHEET_FIELDS, (float(x) for x in row))) for row in zip(*cols)]


def both_paths(points):
    """Every ``(point, load path)`` pair: each point along both load paths, in order."""
    return [(p, path) for p in points for path in PATHS]


def solve_key(p, path):
    """The journal key of one solve: the sheet's parameters and the load path,
    as JSON (with the planform's description, ``p["planform"]``, where a
    sample point has one)."""
    key = [p["length"], p["tip_width"], p["curvature"], p["thickness"], p["modulus"], path]
    if "planform" in p:
        key.append(p["planform"])
    return json.dumps(key)


def coarse_fields(r):
    """The coarse start's part of a record: its mesh, its work (factorisations
    and Newton iterations on the coarse mesh, not in ``factorizations``) and
    why it fell back to the path on the fine mesh ("" if it did not)."""
    return dict(coarse_hmax=r.coarse_hmax, coarse_factorizations=r.coarse_factorizations,
                coarse_newton_iterations=r.start_record.coarse_newton_iterations,
                coarse_fallback=r.coarse_fallback)


def add_start_option(ap):
    """``--start coarse|path`` and ``--coarse-hmax H``: ``solve``'s start
    strategy and coarse mesh for every solve (default: ``solve``'s own)."""
    ap.add_argument("--start", choices=("coarse", "path"), default="coarse",
                    help="solve's start strategy (default: coarse, solve's default)")
    ap.add_argument("--coarse-hmax", type=float, default=None,
                    help="the coarse start's mesh (default: solve's, 0.1)")


def start_options(args):
    """``solve`` keywords of :func:`add_start_option`'s options."""
    out = {"start": args.start}
    if args.coarse_hmax is not None:
        out["coarse_hmax"] = args.coarse_hmax
    return out


def solve_or_crash(p, path, hmax, fields, options=None):
    """One solve of sample point ``p`` at ``min(hmax, L/2)`` as a JSON-ready record
    (``options``: further keywords of ``solve``, e.g. :func:`start_options`).

    ``status`` is ``converged`` (full load reached), ``failed`` (a cleanly
    reported failure, ``on_failure="return"``) or ``crash`` (an exception
    escaped ``solve``: ``error``, ``traceback``, ``wall_time_s``); the fields
    of a converged or failed solve are ``fields(result)`` (a dict).
    """
    t0 = time.perf_counter()
    try:
        r = solve(Sheet(**{k: p[k] for k in SHEET_FIELDS}), path=path,
                  hmax=min(hmax, p["length"] / 2), on_failure="return", **(options or {}))
    except Exception as err:  # noqa: BLE001 - a crash is what these benchmarks count
        return dict(status="crash", error=f"{type(err).__name__}: {err}",
                    traceback=traceback.format_exc(), wall_time_s=time.perf_counter() - t0)
    return dict(status="converged" if r.converged else "failed", **fields(r))


def _snaps(rec):
    return [(s["phase"], float(s["load"])) for s in rec.get("snaps") or []]


def compare_journals(a_path, b_path, d_tol=1e-6, load_tol=1e-3):
    """Two journals of ``stress.py`` or ``snap_sample.py`` (their ``--compare``)
    paired solve by solve; prints the report and returns 1 if any solve differs.

    Whether every solve ends alike (status, stability; the same snaps, phase
    by phase, their located fold loads within ``load_tol``; where the snaps
    agree, d within ``d_tol``), every difference, the coarse start's
    fallbacks by reason, and the totals of Newton iterations and
    factorisations on the mesh of the solve and on the coarse mesh.
    """
    A, B = read_jsonl(a_path), read_jsonl(b_path)
    keys = [k for k in A if k in B]
    print(f"{len(keys)} solves paired ({len(A)} in {a_path}, {len(B)} in {b_path})")
    totals = Counter()
    differ, reasons, d_max, load_max = [], Counter(), 0.0, 0.0
    for k in keys:
        a, b = A[k], B[k]
        for name, rec in (("before", a), ("after", b)):
            for field in ("newton_iterations", "factorizations", "coarse_factorizations",
                          "coarse_newton_iterations"):
                totals[f"{name} {field}"] += rec.get(field) or 0
        if b.get("coarse_fallback"):
            reasons[b["coarse_fallback"].split(":")[0]] += 1
        if (a["status"], a.get("stable")) != (b["status"], b.get("stable")):
            differ.append(f"{k}: status/stable {a['status']}/{a.get('stable')} -> "
                          f"{b['status']}/{b.get('stable')}")
            continue
        sa, sb = _snaps(a), _snaps(b)
        if len(sa) != len(sb) or any(x[0] != y[0] or abs(x[1] - y[1]) > load_tol
                                     for x, y in zip(sa, sb)):
            differ.append(f"{k}: snaps {sa} -> {sb} (d {a.get('deflection')!r} -> "
                          f"{b.get('deflection')!r})")
            continue
        load_max = max([load_max] + [abs(x[1] - y[1]) for x, y in zip(sa, sb)])
        if a["status"] == "converged":
            d = abs(a["deflection"] - b["deflection"])
            d_max = max(d_max, d)
            if d > d_tol:
                differ.append(f"{k}: d {a['deflection']!r} -> {b['deflection']!r}")
    print(f"same status, stability and snaps: {len(keys) - len(differ)} of {len(keys)}; "
          f"largest |d change| there {d_max:.2g}, largest fold-load change {load_max:.2g}")
    not_stable = sum(1 for k in keys if B[k]["status"] == "converged"
                     and B[k].get("stable") is not True)
    print(f"converged but not verified stable (after): {not_stable}")
    for name in ("before", "after"):
        print(f"{name:6s}: Newton {totals[f'{name} newton_iterations']}, factorisations "
              f"{totals[f'{name} factorizations']} on the mesh of the solve; coarse mesh: "
              f"Newton {totals[f'{name} coarse_newton_iterations']}, factorisations "
              f"{totals[f'{name} coarse_factorizations']}")
    print(f"coarse start fell back to the path (after): {sum(reasons.values())}"
          + "".join(f"\n  {n:3d}  {r}" for r, n in reasons.most_common()))
    print(f"differences: {len(differ)}" + "".join(f"\n  {x}" for x in differ))
    return 1 if differ else 0


def read_jsonl(out):
    """``{key: record}`` of a JSON-lines journal (a line cut by a kill is
    skipped and recomputed): the package's journal reader
    (:func:`skfem_sheet.studies.runner.read_journal`) on the stored keys."""
    return read_journal(out, key_of=lambda rec: rec["key"], required=("key",))


def add_shard_option(ap):
    """The ``--shard k:n`` option (several processes sharing one journal)."""
    ap.add_argument("--shard", default="0:1",
                    help="k:n runs every n-th solve starting at k (several processes can "
                         "share one --out file; a last run without --shard prints the table)")


def parse_shard(text):
    """``"k:n"`` as ``(k, n)``.

    Examples
    --------
    >>> parse_shard("1:3")
    (1, 3)
    """
    k, n = (int(x) for x in text.split(":"))
    return k, n


def run_journalled(todo, out, run, shard=(0, 1), reverse=False, progress=None, report=None):
    """Solve the shard's ``(point, path)`` pairs of ``todo`` not yet in journal ``out``.

    Parameters
    ----------
    todo : list of (dict, str)
        Sample points and load paths, in order.
    out : str
        The JSON-lines journal: each finished solve is appended at once as
        ``dict(key=solve_key(p, path), path=path, **p, **run(p, path))``,
        flushed and fsync-ed; solves whose key is in it are skipped (resume),
        and a last line cut by a kill is ended first (skipped when read).
    run : callable
        ``run(p, path) -> dict``, one solve's record.
    shard : (int, int)
        ``(k, n)``: the solves ``k, k + n, k + 2n, ...`` of ``todo``.
    reverse : bool
        Work through the shard from its end, re-reading the journal before
        each solve (a second process on the same shard).
    progress : str, optional
        Label of a tqdm progress bar over the shard (none without it).
    report : callable, optional
        ``report(i, n, p, path, rec)`` after each new solve (``i`` 0-based in the shard).

    Returns
    -------
    dict
        ``{key: record}`` of the journal as this process has seen it.
    """
    k_shard, n_shard = shard
    done = read_jsonl(out)
    mine = [t for i, t in enumerate(todo) if i % n_shard == k_shard]
    if reverse:
        mine = mine[::-1]
    items = mine
    if progress:
        items = tqdm(mine, desc=progress, unit="solve")
    with open(out, "a+b") as f:
        if f.seek(0, os.SEEK_END):
            f.seek(-1, os.SEEK_END)
            if f.read(1) != b"\n":  # a line cut by a kill: end it (not glued to the next)
                f.write(b"\n")
        for i, (p, path) in enumerate(items):
            k = solve_key(p, path)
            if k in done or (reverse and k in read_jsonl(out)):
                continue
            rec = dict(key=k, path=path, **p, **run(p, path))
            f.write((json.dumps(rec, default=float) + "\n").encode())
            f.flush()
            os.fsync(f.fileno())
            done[k] = rec
            if report is not None:
                report(i, len(mine), p, path, rec)
    return done


# ---------------------------------------------------------------------------
# Small utilities
# ---------------------------------------------------------------------------
def add_run_options(ap, name):
    """The command-line options shared by the three benchmarks."""
    ap.add_argument("--json", default=f"{name}.json",
                    help=f"results, rewritten after every solve (default {name}.json)")
    ap.add_argument("--png", default=f"{name}.png", help=f"plot (default {name}.png; '' for none)")
    ap.add_argument("--timeout", type=float, default=None,
                    help="seconds after which a solve is killed")
    ap.add_argument("--threads", type=int, default=None,
                    help="MKL/OpenMP threads per solve (default: the libraries' own)")
    ap.add_argument("--force", action="store_true", help="redo solves already in --json")
    ap.add_argument("--retry", action="store_true", help="redo recorded solves that did not "
                    "converge (failed, crashed, timed out)")
    ap.add_argument("--reuse-stale", action="store_true",
                    help="reuse recorded solves made with other skfem_sheet sources "
                         "(by default they are redone)")
    ap.add_argument("--verbose", action="store_true", help="show each solve's progress bar")


def interrupted(args):
    """Message and exit code (130) after Ctrl-C: finished solves stay in the JSON."""
    print(f"\ninterrupted: the finished solves are kept in {args.json}; run the same "
          "command again to continue", file=sys.stderr)
    return 130


def open_store(args, name):
    """A :class:`RunStore` for the parsed options; says which runs are stale."""
    store = RunStore(args.json, name, force=args.force, retry=args.retry,
                     reuse_stale=args.reuse_stale)
    stale = store.stale()
    if stale and not args.force:
        print(f"note: {len(stale)} run(s) in {args.json} were made with other skfem_sheet "
              f"sources ({', '.join(sorted({str(r.get('code')) for r in stale}))}; now "
              f"{store.code}): " + ("reused (--reuse-stale)" if args.reuse_stale
                                    else "they are redone when needed"), file=sys.stderr)
    return store


def parse_family(text):
    """Parse ``"0.12:2,0.085:3"`` into ``[(0.12, 2), (0.085, 3)]`` (``:auto`` = None).

    Examples
    --------
    >>> parse_family("0.12:2, 0.085:3,0.06")
    [(0.12, 2), (0.085, 3), (0.06, None)]
    """
    out = []
    for item in text.split(","):
        item = item.strip()
        if not item:
            continue
        hs, _, ls = item.partition(":")
        ls = ls.strip()
        out.append((float(hs), None if ls in ("", "auto") else int(ls)))
    return out


def fmt(x, spec, missing="-"):
    """``format(x, spec)``, or ``missing`` for None / NaN."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return missing
    return format(x, spec)


def machine_info():
    """Where and how the benchmark ran (recorded in the JSON)."""
    info = dict(python=sys.version.split()[0], platform=platform.platform(),
                cpus=os.cpu_count(), skfem_sheet=getattr(skfem_sheet, "__version__", "?"),
                backends=available_backends(),
                date=time.strftime("%Y-%m-%d %H:%M:%S"))
    try:
        info["load_average_at_start"] = list(os.getloadavg())
    except OSError:  # no load average on this platform
        pass
    for var in ("MKL_NUM_THREADS", "OMP_NUM_THREADS"):
        if var in os.environ:
            info[var] = os.environ[var]
    return info


def warn_if_busy(threshold=0.5):
    """Print a warning to stderr when the 1-minute load average says others run."""
    try:
        load = os.getloadavg()[0]
    except OSError:  # no load average on this platform
        return
    if load > threshold:
        print(f"warning: load average {load:.2f} before starting: timings are only "
              "meaningful on a quiet machine", file=sys.stderr)


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "--child":
        _child(sys.argv[2], sys.argv[3])
    else:
        sys.exit("usage: python common.py --child SPEC_JSON OUT_JSON (internal)")
