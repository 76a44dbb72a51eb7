"""The public solver: ``solve(sheet, path=..., hmax=...) -> Result``."""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from functools import lru_cache
from typing import ClassVar

import numpy as np

from .analyses.observables import tip_deflection
from .analyses.transfer import transfer
from .continuation import PATHS, StepOptions, end_state_verdict, follow_path, load_phases
from .io import write_result
from .linalg import make_linear_solver
from .mesh import estimate_dofs, sheet_mesh
from .newton import NewtonOptions, Stats, newton, polish
from .params import ParameterError, Sheet, check_range
from .problem import SheetProblem
from .version import __version__

__all__ = ["Result", "SolveError", "solve", "build_problem", "MAX_DOFS", "STARTS",
           "COARSE_HMAX", "MIN_COARSENING", "LATE_SNAP", "RESUME_MARGIN", "RESUME_TRIES", "FOLD_SHIFT", "FINISH_ITERATIONS", "FINAL_UTOL",
           "POLISH_ITERATIONS"]

#: Largest problem accepted (about 6 GB of factor with PARDISO on 2 cores).
MAX_DOFS = 1_500_000

#: Ways :func:`solve` reaches full load: the load path on the mesh asked for
#: (``"path"``), or the load path on a coarse mesh finished on it (``"coarse"``).
STARTS = ("path", "coarse")

#: Default mesh size of the coarse load path of ``start="coarse"``.
COARSE_HMAX = 0.1

#: With the default coarse mesh (``coarse_hmax=COARSE_HMAX``) the coarse path runs
#: only where it is at least this much coarser than ``hmax``
#: (``COARSE_HMAX >= MIN_COARSENING * hmax``); closer, it costs about as much
#: as the path on ``hmax`` (the issue-17 sheet at hmax 0.08 from 0.1: 98
#: coarse + 38 fine Newton iterations against 75 for the path), which then
#: runs instead.  An explicit ``coarse_hmax`` is used whenever it is coarser.
MIN_COARSENING = 2.0

#: The fine path resumes from the coarse path's last accepted state of the
#: snapping phase at ``lam <= lam_snap - RESUME_MARGIN`` (the phase's start if
#: there is none), so that it starts on the branch the coarse path was
#: following, before the fine fold.  Folds move little between the meshes:
#: the snap loads recorded at hmax 0.1 and 0.03 differ by 0.004-0.014 of the
#: phase, either way, on the four snapping solves of the sample of
#: ``benchmarks/solve_sample.py`` (seed 16; less than one ``snap_step``, the
#: resolution of the record), and by 0.017 between 0.1 and 0.08 on the sheet
#: of issue 17.  (A coarse
#: path that holds its branch to full load is taken to decide the fine mesh's
#: branch: no fold was seen to move from beyond full load on the coarse mesh
#: to before it on the finer one.)
RESUME_MARGIN = 0.05

#: Coarse states (going back from the one :data:`RESUME_MARGIN` before the
#: snap) from which the fine Newton is tried before the resume fails.
RESUME_TRIES = 3

#: How far (fraction of the phase) a fold is taken to move at most between the
#: coarse mesh and the fine one: six times the largest shift measured (see
#: :data:`RESUME_MARGIN`).  A resumed fine path whose branch ends (steps cut
#: below ``StepOptions.snap_step``) within this of the late coarse snap ends
#: at the coarse fold: the sheet snaps there on the fine mesh too, onto the
#: branch the coarse path snapped to (its end state is finished on the fine
#: mesh instead of a snap settle there).
FOLD_SHIFT = 0.1

#: A coarse path that snapped in its last phase at ``lam >= 1 - LATE_SNAP`` of
#: that phase (or at full load, leaving an unstable end state) does not decide
#: the branch of the fine mesh: its fold may lie beyond full load there, and
#: ``start="coarse"`` resumes the load path on the fine mesh from the coarse
#: state before the snap (:data:`RESUME_MARGIN`), so that the fine mesh
#: decides.  An earlier snap has its fine fold before full load too (it moves
#: at most :data:`FOLD_SHIFT`), so the fine sheet snaps onto the branch the
#: coarse path snapped to, and the coarse end state is finished on the fine
#: mesh like that of a path without a snap.  Hence the same margin: a resumed
#: probe of an earlier snap only ever found the fine branch ending near the
#: coarse fold, at the cost of a fine path through the fold (the sheet L 1.474,
#: b 0.711, a/R 4.845, gravity-first, snapping at 0.779: 37 fine
#: factorisations with the probe, 4 without; both the same end state as the
#: whole fine path).
LATE_SNAP = FOLD_SHIFT

#: Newton iterations allowed to finish a transferred coarse state on the fine
#: mesh (at least ``NewtonOptions.max_iterations``); beyond them the state is
#: taken through a mesh between the two, and if that fails too the fine path
#: runs instead.
FINISH_ITERATIONS = 8

#: Tolerance (units of a) of the last displacement correction of the final
#: polish of every converged solve (both starts): the load path's (or the
#: fine finish's) Newton solve stops when the next correction is below
#: ``NewtonOptions.utol`` (1e-6) without applying it; the polish applies
#: simplified Newton corrections with the factorisation at hand
#: (back-substitutions only, no factorisation) until one is at most
#: ``FINAL_UTOL``.  Two solves of one equilibrium (e.g. the two starts) then
#: agree in d to about ``FINAL_UTOL`` instead of ``utol`` (1e-6 relative
#: also where d is 0.007).
FINAL_UTOL = 1e-9

#: Most corrections of the final polish (it stops early, keeping the state it
#: has, if a correction does not shrink to at most half the previous one).
POLISH_ITERATIONS = 4


class SolveError(RuntimeError):
    """A solve that did not reach full load; ``.result`` holds how far it got."""

    def __init__(self, message, result=None):
        super().__init__(message)
        self.result = result


@dataclass(frozen=True)
class Result:
    """Outcome of :func:`solve`.

    Attributes
    ----------
    sheet : Sheet
    path : str
    hmax : float
    deflection : float
        Tip deflection d/a, positive downward (at the last converged load if
        ``converged`` is False).
    converged : bool
        True only if the full load (curvature and gravity) was reached.
    message : str
        Why not, when not converged.
    kappa, gravity : float
        Load reached (curvature a/R and gravity factor).
    dofs : int
    newton_iterations, factorizations, load_steps, rejected_steps : int
    back_substitutions : int
        Right-hand sides solved with a factorisation (as the linear solver counts them).
    wall_time_s, assembly_s, linear_solve_s : float
    energy : float
        Total potential energy at the last converged load.
    volume_change : float
        Relative change of the volume, ``int J dV / V - 1``.
    solver : str
        Linear-solver back-end used.
    steps : tuple
        ``(phase, lam, newton iterations)`` of each accepted step.
    snaps : tuple
        ``(phase, lam, kappa, g)`` where the followed branch ended at a fold and
        the sheet snapped to the other one (empty if the branch held).
    symmetric : bool
        Solved as the mirror-symmetric half (see :func:`solve`).
    branch : str
        ``"curvature-dominated"`` or ``"gravity-dominated"``: the branch the
        load path selects (curvature-first: curvature-dominated), switched if
        the path snapped (a jump of more than 0.1 max(1, L) in a step below
        ``StepOptions.snap_step``).  The label is the history of the load
        path, not a property of the end state: outside the bistable range both
        paths reach the same state, whatever its name.  With
        ``start="coarse"`` the history is the coarse path's up to where the
        fine mesh takes over (full load; or, after a late coarse snap, the
        resumed load, and the fine path's history from there), so a fold
        near full load, which one mesh may have before full load and the
        other not, is the fine mesh's to decide.  A fold crossed within one
        load step without a recorded snap is not in the history of either
        (what is recorded is the load path's guard's decision).
    stable : bool or None
        Whether the equilibrium is stable: the constrained Hessian (the tangent
        on the incompressible subspace) is positive definite, read off the
        inertia of the last factorised tangent (``None`` if the linear solver
        cannot tell, also after refactorising at the end state).  For a
        symmetric solve, stability against symmetric perturbations.  The load
        path verifies it: a converged result is never known to be unstable
        (an unstable end state is left along its unstable eigenvector, a snap
        recorded in ``snaps``, or the solve fails saying that it ended on an
        unstable equilibrium; see :func:`~skfem_sheet.continuation.follow_path`).
    negative_eigenvalues : int or None
        Number of negative eigenvalues of the constrained Hessian.
    refine : int
        Nested refinements of the mesh made at ``hmax`` (``layers`` counts
        the layers after refinement).
    start : str
        ``start`` asked of :func:`solve` (``"path"`` or ``"coarse"``).
    coarse_hmax : float
        Mesh size of the coarse path of ``start="coarse"`` (as asked; no
        coarse path runs with ``start="path"``).
    coarse_fallback : str
        Why the coarse path was not used and the load path ran on the fine
        mesh instead (empty if it was used, or not asked for).
    coarse_factorizations, coarse_newton_iterations : int
        Work on the coarse mesh and an intermediate one (0 without them); ``factorizations`` and
        ``newton_iterations`` count the mesh ``hmax`` only (including a
        finishing attempt that fell back, and a resumed fine path),
        ``wall_time_s`` includes the coarse path.
    coarse_resume : str
        Why and where the load path resumed on the mesh ``hmax`` from a
        state of the coarse path (a late coarse snap, see :data:`LATE_SNAP`),
        e.g. ``"coarse path snapped late in its curvature phase (at 0.8);
        resumed at curvature 0.69"``; empty otherwise.
    target_gravity : float
        The full gravity load asked of :func:`solve` (``gravity``; a
        fraction of the sheet's own weight); ``gravity`` is the load reached.
    polish_iterations : int
        Simplified-Newton corrections of the final polish (:data:`FINAL_UTOL`;
        their back-substitutions are counted in ``back_substitutions``).
    """

    sheet: Sheet
    path: str
    hmax: float
    deflection: float
    converged: bool
    message: str
    kappa: float
    gravity: float
    dofs: int
    newton_iterations: int
    factorizations: int
    load_steps: int
    rejected_steps: int
    wall_time_s: float
    assembly_s: float
    linear_solve_s: float
    energy: float
    volume_change: float
    solver: str
    layers: int
    steps: tuple = ()
    snaps: tuple = ()
    symmetric: bool = False
    branch: str = ""
    stable: object = None
    negative_eigenvalues: object = None
    refine: int = 0
    back_substitutions: int = 0
    start: str = "path"
    coarse_hmax: float = COARSE_HMAX
    coarse_fallback: str = ""
    coarse_factorizations: int = 0
    coarse_newton_iterations: int = 0
    coarse_resume: str = ""
    polish_iterations: int = 0
    target_gravity: float = 1.0
    problem: SheetProblem = field(default=None, repr=False, compare=False)
    w: np.ndarray = field(default=None, repr=False, compare=False)

    # -- derived fields ------------------------------------------------------
    @property
    def displacement(self):
        """Nodal displacements of the quadratic nodes, shape (n_nodes, 3)."""
        return self.problem.split(self.w)[0]

    @property
    def pressure(self):
        """Vertex pressures in the paper's convention (``mu`` at rest)."""
        return self.problem.paper_pressure(self.w)

    @property
    def energy_density(self):
        """psi/mu = (I_C - 3)/2 per tetrahedron (computed on demand)."""
        return self.problem.energy_density(self.w)

    #: The fields of :meth:`to_record`, in order, with their kinds: ``"float"``,
    #: ``"int"`` (may be missing), ``"bool"``, ``"bool?"`` (True, False or
    #: unknown) and ``"str"``; and how each is read off a Result.  The one
    #: definition of a result row (the sweep's columns and dtypes derive from it).
    RECORD_FIELDS: ClassVar[tuple] = (
        ("length", "float", lambda r: r.sheet.length),
        ("tip_width", "float", lambda r: r.sheet.tip_width),
        ("curvature", "float", lambda r: r.sheet.curvature),
        ("thickness", "float", lambda r: r.sheet.thickness),
        ("modulus", "float", lambda r: r.sheet.modulus),
        ("path", "str", lambda r: r.path),
        ("hmax", "float", lambda r: r.hmax),
        ("refine", "int", lambda r: r.refine),
        ("symmetric", "bool", lambda r: r.symmetric),
        ("deflection", "float", lambda r: r.deflection),
        ("converged", "bool", lambda r: r.converged),
        ("message", "str", lambda r: r.message or ""),
        ("branch", "str", lambda r: r.branch),
        ("stable", "bool?", lambda r: r.stable),
        ("negative_eigenvalues", "int", lambda r: r.negative_eigenvalues),
        ("snapped", "bool?", lambda r: len(r.snaps) > 0),
        ("newton_iterations", "int", lambda r: r.newton_iterations),
        ("load_steps", "int", lambda r: r.load_steps),
        ("wall_time_s", "float", lambda r: r.wall_time_s),
        ("assembly_s", "float", lambda r: r.assembly_s),
        ("linear_solve_s", "float", lambda r: r.linear_solve_s),
        ("dofs", "int", lambda r: r.dofs),
        ("energy", "float", lambda r: r.energy),
        ("volume_change", "float", lambda r: r.volume_change),
        ("kappa_reached", "float", lambda r: r.kappa),
        ("gravity_reached", "float", lambda r: r.gravity),
        ("factorizations", "int", lambda r: r.factorizations),
        ("back_substitutions", "int", lambda r: r.back_substitutions),
        ("rejected_steps", "int", lambda r: r.rejected_steps),
        ("linear_solver", "str", lambda r: r.solver),
        ("layers_used", "int", lambda r: r.layers),
        ("start", "str", lambda r: r.start),
        ("coarse_hmax", "float", lambda r: r.coarse_hmax),
        ("coarse_fallback", "str", lambda r: r.coarse_fallback),
        ("coarse_factorizations", "int", lambda r: r.coarse_factorizations),
        ("coarse_newton_iterations", "int", lambda r: r.coarse_newton_iterations),
        ("coarse_resume", "str", lambda r: r.coarse_resume),
        ("polish_iterations", "int", lambda r: r.polish_iterations),
        ("gravity", "float", lambda r: r.target_gravity),
    )

    def to_record(self) -> dict:
        """The result as one flat row: parameters and outputs, plain Python values.

        The one definition of a result row (:data:`RECORD_FIELDS`): a sweep's
        table (:mod:`skfem_sheet.studies.sweep`) holds these columns, and
        :meth:`summary` is made from it.  ``snapped`` is whether the path
        snapped to the other branch; ``kappa_reached``/``gravity_reached`` the
        load reached; ``linear_solver`` the back-end used; ``layers_used`` the
        layers of the mesh solved.

        Examples
        --------
        >>> r = solve(Sheet(length=0.5), hmax=0.1)
        >>> rec = r.to_record()
        >>> rec["length"], rec["converged"], rec["deflection"] == r.deflection
        (0.5, True, True)
        >>> list(rec) == [name for name, _, _ in Result.RECORD_FIELDS]
        True
        """
        out = {}
        for name, kind, get in self.RECORD_FIELDS:
            v = get(self)
            if kind == "float":
                v = float(v)
            elif kind == "bool":
                v = bool(v)
            elif v is not None:
                v = {"int": int, "bool?": bool, "str": str}[kind](v)
            out[name] = v
        return out

    def summary(self) -> dict:
        """JSON-ready summary (the CLI's ``--json`` contents), made from :meth:`to_record`.

        The record's fields, with the sheet and mesh parameters grouped under
        ``params`` (``layers`` there: the layers solved), ``solver`` the
        back-end used; then the ``steps`` and ``snaps`` and the ``version``.
        """
        rec = self.to_record()
        params = {k: rec.pop(k) for k in ("length", "tip_width", "curvature", "thickness",
                                          "modulus", "gravity", "hmax")}
        params.update(layers=rec.pop("layers_used"), refine=rec.pop("refine"))
        out = {k: rec.pop(k) for k in (
            "deflection", "converged", "message", "path", "dofs", "newton_iterations",
            "factorizations", "back_substitutions", "load_steps", "rejected_steps", "wall_time_s", "linear_solve_s",
            "assembly_s", "energy", "volume_change", "kappa_reached", "gravity_reached")}
        out["solver"] = rec.pop("linear_solver")
        out.update(rec)  # symmetric, branch, stable, ... and any field added to the record
        out["params"] = params
        out.update(steps=[list(x) for x in self.steps], snaps=[list(x) for x in self.snaps],
                   version=__version__)
        return out

    def write(self, filename):
        """Write the deformed sheet (``.vtu``: displacement, pressure, psi/mu) or
        the summary (``.json``)."""
        write_result(self, filename)


def _back_substitutions(linear) -> int:
    """Right-hand sides the linear solver back-substituted (0 if it does not count)."""
    counts = getattr(linear, "counts", None)
    return int(counts.back_substitutions) if counts is not None else 0


def build_problem(sheet: Sheet, hmax: float, layers=None, quadrature_order: int = 2,
                  half: bool = False, refine: int = 0) -> SheetProblem:
    """The discrete problem :func:`solve` solves: ``sheet`` on its mesh
    (:func:`~skfem_sheet.mesh.sheet_mesh` with ``hmax``, ``layers``,
    ``half``, ``refine``), cached (the same arguments give the same object).

    Examples
    --------
    >>> p = build_problem(Sheet(length=0.5), 0.15, None, 2, half=True)
    >>> p.sheet_mesh.half, p is build_problem(Sheet(length=0.5), 0.15, None, 2, half=True)
    (True, True)
    """
    return _cached_problem(sheet, hmax, layers, quadrature_order, half, refine)


@lru_cache(maxsize=8)
def _cached_problem(sheet, hmax, layers, quadrature_order, half, refine):
    return SheetProblem(sheet, sheet_mesh(sheet, hmax, layers, half=half, refine=refine),
                        quadrature_order)


def solve(sheet: Sheet, path: str = "curvature-first", hmax: float = 0.03, *,
          layers=None, refine: int = 0, solver: str = "auto", quadrature_order: int = 2,
          symmetric: bool = True,
          newton_options: NewtonOptions | None = None,
          step_options: StepOptions | None = None,
          on_failure: str = "raise", progress: bool = False, series=None,
          start: str = "coarse", coarse_hmax: float = COARSE_HMAX,
          gravity: float = 1.0) -> Result:
    """Equilibrium of a clamped, curved sheet under its own weight.

    Parameters
    ----------
    sheet : Sheet
    path : {"curvature-first", "gravity-first"}
        Load path, which selects the branch in the bistable range.
    hmax : float
        Mesh size (in-plane edge length; layers through the thickness are at
        most ``hmax`` thick).
    layers : int, optional
        Number of element layers through the thickness.
    refine : int
        Nested mesh refinement, 0 to 4 (default 0): the mesh made at ``hmax``
        with ``layers`` layers has every edge halved ``refine`` times in all
        three directions (each triangle of the plan split into four,
        ``layers * 2**refine`` layers; 8x the elements per step).  Meshes with
        the same ``hmax`` and ``layers`` and increasing ``refine`` are nested:
        the clean sequence for convergence studies.
    solver : {"auto", "pardiso", "superlu"}
        Linear-solver back-end (see :mod:`skfem_sheet.linalg`).
    quadrature_order : {2, 3, 4}
    symmetric : bool
        Solve the mirror-symmetric half ``y >= 0`` with ``U_y = 0`` on
        ``y = 0`` (default): half the unknowns, the same answer to round-off
        whenever the equilibrium is symmetric (its mesh is exactly the half of
        the full one).  ``False`` solves the whole sheet, which also admits
        asymmetric (e.g. twisting) shapes and perturbations.
    on_failure : {"raise", "return"}
        If the full load is not reached: raise :class:`SolveError` (default)
        or return a :class:`Result` with ``converged=False``.
    progress : bool
        Show a progress bar on stderr.
    series : skfem_sheet.io.Series, optional
        Collects the state of every accepted load step (``series.write``
        writes them as a ParaView series); nothing is kept when None.
        With ``start="coarse"`` only the states on the mesh ``hmax``.
    start : {"coarse", "path"}
        ``"coarse"`` (default): the load path on the mesh ``coarse_hmax``
        (seconds), its end state transferred to the mesh ``hmax``
        (:func:`~skfem_sheet.analyses.transfer.transfer`) and finished there
        by Newton at full load, keeping the branch the coarse path selected
        (``snaps``, ``steps`` and ``branch`` are then the coarse path's, the
        last step ``("fine", 1.0, iterations)``).  ``"path"``: the load path
        on the mesh ``hmax`` from the reference state (the default before
        the coarse start was measured at hmax 0.03; a sweep journal's row
        without a ``start`` is a ``"path"`` row).

        Where the coarse path snapped late in its last phase
        (:data:`LATE_SNAP`: near a fold the meshes may disagree about the
        branch), the load path resumes on the mesh ``hmax`` from the coarse
        state :data:`RESUME_MARGIN` before the snap (transferred and solved
        there by Newton: a step ``("fine", lam, iterations)``), and the fine
        mesh decides whether it snaps: ``steps`` and ``snaps`` are the coarse
        path's up to there, then the fine path's (``coarse_resume`` says
        where).  The load path runs on the mesh ``hmax`` from the start
        instead (``coarse_fallback`` says why) when the coarse path failed,
        or the fine Newton fails within :data:`FINISH_ITERATIONS` also after
        a detour through the mesh ``sqrt(coarse_hmax hmax)`` (a step
        ``("intermediate", 1.0, iterations)``, its work counted with the
        coarse mesh's), or it moves a node by more than ``0.1 max(1, L)``
        from the coarse state (a jump of branch), or the fine end state is
        not known to be stable (by the load paths' own end-state check,
        :func:`~skfem_sheet.continuation.end_state_verdict`), or a resumed
        fine path did not reach full load.  Measured against the fine path
        at hmax 0.03 on a random sample of 12 sheets and both paths and the
        four cases of ``benchmarks/solve_speed.py``
        (``benchmarks/results/solve_sample_hmax0.03_coarse_vs_path.txt``,
        ``..._coarse_vs_path_d.txt``): the same end state on all 28 solves,
        d to 2.7e-7 relative, the fine mesh's factorisations median 4, at
        most 6 (the path's: median 32, at most 97).  The ``branch`` label
        differs on one of them, where the coarse path crosses a fold within
        one load step without recording a snap (the fine path records it):
        the label is the recorded history.

        Either way a converged end state is polished to :data:`FINAL_UTOL`
        by back-substitutions with the last factorisation
        (``polish_iterations``).
    gravity : float
        The gravity load as a fraction of the sheet's own weight, in [0, 10]
        (default 1; 0: no gravity, the clamp's curvature alone, one phase
        on both paths).
    coarse_hmax : float
        Mesh size of the coarse path; with ``coarse_hmax <= hmax`` the load
        path runs on the mesh ``hmax``.  The default, :data:`COARSE_HMAX`,
        is used only where it is at least :data:`MIN_COARSENING` times
        ``hmax`` (else the load path runs on the mesh ``hmax``, and
        ``coarse_fallback`` says so); any other value whenever it is coarser.

    Returns
    -------
    Result

    Examples
    --------
    >>> r = solve(Sheet(length=0.5), hmax=0.1)
    >>> r.converged, 0.09 < r.deflection < 0.11
    (True, True)
    """
    if not isinstance(sheet, Sheet):
        raise ParameterError(f"sheet must be a skfem_sheet.Sheet, got {type(sheet).__name__}")
    if path not in PATHS:
        raise ParameterError(f"path must be one of {', '.join(PATHS)}, got {path!r}")
    if start not in STARTS:
        raise ParameterError(f"start must be one of {', '.join(STARTS)}, got {start!r}")
    coarse_hmax = check_range("coarse_hmax", coarse_hmax, 0, None, lo_open=True)
    if on_failure not in ("raise", "return"):
        raise ParameterError(f"on_failure must be 'raise' or 'return', got {on_failure!r}")
    if quadrature_order not in (2, 3, 4):
        raise ParameterError(f"quadrature_order must be one of 2, 3, 4, got {quadrature_order!r}")
    hmax = check_range("hmax", hmax, 0, None, lo_open=True)
    gravity = check_range("gravity", gravity, 0, 10,
                          hint="a fraction of the sheet's own weight")
    if not isinstance(symmetric, (bool, np.bool_)):
        raise ParameterError(f"symmetric must be True or False, got {symmetric!r}")
    if series is not None and not callable(getattr(series, "on_step", None)):
        raise ParameterError(f"series must be a skfem_sheet.io.Series, got {series!r}")
    ndofs = estimate_dofs(sheet, hmax, layers, half=symmetric, refine=refine)
    if ndofs > MAX_DOFS:
        what = f"hmax={hmax:g}" + (f" with refine={refine}" if refine else "")
        raise ParameterError(f"hmax must be larger{' or refine smaller' if refine else ''}: "
                         f"{what} gives about {ndofs:,} unknowns, "
                         f"more than the {MAX_DOFS:,} that fit in memory here")
    linear = make_linear_solver(solver)
    for name, value, kind in (("newton_options", newton_options, NewtonOptions),
                              ("step_options", step_options, StepOptions)):
        if value is not None and not isinstance(value, kind):
            raise ParameterError(f"{name} must be a {kind.__name__} or None, "
                                 f"got {type(value).__name__}")
    newton_options = newton_options or NewtonOptions()
    step_options = step_options or StepOptions()

    t0 = time.perf_counter()
    stats = Stats()
    problem = build_problem(sheet, hmax, layers, quadrature_order, bool(symmetric), int(refine))
    if getattr(linear, "needs_layout", False):  # the saddle-point structure (pyamg)
        linear.attach(problem.saddle_point_layout())
    bar = None
    if progress:
        # deferred: only progress bars need tqdm
        from tqdm.auto import tqdm

        bar = tqdm(total=100, desc=f"{path} L={sheet.length:g} b={sheet.tip_width:g} "
                   f"a/R={sheet.curvature:g}", unit="%", leave=False)

    def report(frac):
        if bar is not None:
            bar.n = round(100 * frac)
            bar.set_postfix(newton=stats.newton_iterations, refresh=False)
            bar.refresh()

    cstats = Stats()
    fallback = ""
    out = None
    # the series' frames are passed on one step late, so that the last one
    # can be the polished end state (the Result's)
    pending = []

    def on_step(pr, w_step, k, g):
        if pending:
            series.on_step(*pending.pop())
        pending.append((pr, np.array(w_step, dtype=float), k, g))

    hook = None if series is None else on_step
    try:
        if start == "coarse":
            if coarse_hmax <= hmax:
                fallback = f"coarse_hmax {coarse_hmax:g} is not coarser than hmax {hmax:g}"
            elif coarse_hmax == COARSE_HMAX and coarse_hmax < MIN_COARSENING * hmax:
                fallback = (f"the default coarse mesh (hmax {coarse_hmax:g}) is less than "
                            f"{MIN_COARSENING:g} times coarser than hmax {hmax:g}: the path "
                            f"on hmax costs about as much")
            else:
                cproblem = build_problem(sheet, coarse_hmax, None, quadrature_order,
                                         bool(symmetric), 0)
                out, fallback = _coarse_to_fine(
                    problem, cproblem, path, sheet.curvature, solver, linear, newton_options,
                    step_options, stats, cstats, report, quadrature_order,
                    hook, gravity)
                if out is not None and series is not None and not out.own_frames:
                    on_step(problem, out.w, out.kappa, out.g)
        if out is None:
            out = _Reached.of_path(follow_path(problem, path, sheet.curvature, linear,
                                               newton_options=newton_options,
                                               step_options=step_options, stats=stats,
                                               progress=report, on_step=hook,
                                               gravity=gravity))
    finally:
        if bar is not None:
            bar.close()
    w, n_polish = out.w, 0
    if out.converged or (out.kappa, out.g) == (sheet.curvature, gravity):
        # both starts: the same tight end state (d to FINAL_UTOL, not utol); also
        # an end state at full load that failed its stability check (solved to
        # the full tolerance all the same)
        w, n_polish = polish(problem, w, out.g, linear, stats, utol=FINAL_UTOL,
                             max_iterations=POLISH_ITERATIONS,
                             first=10 * newton_options.utol)
    if pending:
        pr, w_last, k, g = pending.pop()
        if out.converged and pr is problem and (k, g) == (out.kappa, out.g):
            w_last = w  # the end state, as the Result holds it
        series.on_step(pr, w_last, k, g)
    # the load path verified its end state (the inertia of its tangent)
    stable, n_neg = (out.stable, out.negative_eigenvalues) if out.converged else (None, None)
    result = Result(
        sheet=sheet, path=path, hmax=hmax,
        deflection=tip_deflection(problem, w), converged=out.converged,
        message=out.reason, kappa=out.kappa, gravity=out.g,
        dofs=int(problem.ndof), newton_iterations=stats.newton_iterations,
        factorizations=stats.factorizations, load_steps=len(out.steps),
        rejected_steps=out.rejected_steps,
        wall_time_s=time.perf_counter() - t0, assembly_s=stats.assembly_s,
        linear_solve_s=stats.linear_solve_s,
        energy=problem.energy(w, out.g),
        volume_change=problem.deformed_volume(w) / problem.volume0 - 1.0,
        solver=linear.name, layers=problem.sheet_mesh.layers,
        steps=tuple(out.steps), snaps=tuple(out.snaps), symmetric=bool(symmetric),
        branch=_branch(path, out.snaps), stable=stable, negative_eigenvalues=n_neg,
        refine=int(refine), problem=problem, w=w,
        back_substitutions=_back_substitutions(linear), start=start,
        coarse_hmax=coarse_hmax, coarse_fallback=fallback,
        coarse_factorizations=cstats.factorizations,
        coarse_newton_iterations=cstats.newton_iterations,
        coarse_resume=out.resume, polish_iterations=n_polish, target_gravity=gravity)
    if not out.converged and on_failure == "raise":
        raise SolveError(f"solve did not reach full load: {out.reason}", result)
    return result


@dataclass(frozen=True)
class _Reached:
    """How :func:`solve` reached its end state, whatever the route: the load
    path on the mesh ``hmax`` (:meth:`of_path`), a coarse path finished there,
    or a fine path resumed after a late coarse snap.  What the Result is
    made of."""

    w: np.ndarray
    kappa: float
    g: float
    steps: tuple
    snaps: tuple
    rejected_steps: int
    stable: object
    negative_eigenvalues: object
    converged: bool = True
    reason: str = ""
    resume: str = ""  # where a fine path resumed after a late coarse snap
    own_frames: bool = False  # the end state was passed to on_step already

    @classmethod
    def of_path(cls, out):
        """The outcome of :func:`~skfem_sheet.continuation.follow_path` on the
        mesh ``hmax``."""
        return cls(w=out.w, kappa=out.kappa, g=out.g, steps=tuple(out.steps),
                   snaps=tuple(out.snaps), rejected_steps=out.rejected_steps,
                   stable=out.stable, negative_eigenvalues=out.negative_eigenvalues,
                   converged=out.converged, reason=out.reason)


def _newton_from(src, w_src, dst, kappa, g, linear, opts, stats, guard):
    """The state ``w_src`` of ``src`` transferred to ``dst`` (clamp set to
    ``kappa``) and solved there by Newton at gravity ``g``, its first
    correction at most ``guard``: ``(NewtonResult, transferred state)``."""
    w = transfer(src, w_src, dst)
    w[dst.clamp_dofs] = dst.clamp_values(kappa)
    return newton(dst, w, g, linear, opts, stats, max_first_increment=guard), w


def _resume_load(coarse, states, path, kappa, gravity):
    """Where the fine path resumes after a late coarse snap: ``(index,
    lam_snap, why)``, the state in ``states`` (aligned with ``coarse.steps``)
    to resume from and the load of the snap, or ``None`` if the coarse path
    did not snap late in its last phase."""
    phases = load_phases(path, kappa, gravity)
    if not phases:
        return None
    last = phases[-1][0]
    late = [lam for phase, lam, _, _ in coarse.snaps
            if phase == last and lam >= 1 - LATE_SNAP]
    if len(phases) < 2 or not late or len(states) != len(coarse.steps):
        return None
    lam_snap = min(late)
    # the last accepted state of the last phase RESUME_MARGIN before the snap,
    # else the last state of the phase before (the last phase's start)
    index = None
    for i, (phase, lam, _) in enumerate(coarse.steps):
        if phase == last and lam <= lam_snap - RESUME_MARGIN:
            index = i
        elif phase != last:
            index = i
    if index is None:
        return None
    return index, lam_snap, (f"coarse path snapped late in its {last} phase (at "
                             f"{lam_snap:.3g} of its range)")


def _coarse_to_fine(problem, cproblem, path, kappa, solver, linear, newton_options,
                    step_options, stats, cstats, report, quadrature_order, on_step=None,
                    gravity=1.0):
    """The load path on ``cproblem``, finished on ``problem`` at full load.

    Returns ``(outcome, "")`` if the coarse path's end state, transferred and
    solved by Newton on ``problem``, is a stable equilibrium near it on the
    branch the coarse path selected, or if the coarse path snapped late and
    the load path resumed on ``problem`` from a coarse state before the snap
    reached full load (``outcome.resume`` says where; ``on_step`` sees its
    steps); else ``(None, why)`` (the caller runs the load path on
    ``problem``).  ``stats`` counts the fine mesh's work (also of an attempt
    that fell back), ``cstats`` the coarse mesh's.
    """
    clinear = make_linear_solver(solver)
    if getattr(clinear, "needs_layout", False):
        clinear.attach(cproblem.saddle_point_layout())
    states = []
    coarse = follow_path(cproblem, path, kappa, clinear, newton_options=newton_options,
                         step_options=step_options, stats=cstats,
                         progress=lambda f: report(0.9 * f),
                         on_step=lambda pr, w, k, g: states.append(w.copy()),
                         gravity=gravity)
    if not coarse.converged:
        return None, f"coarse path failed: {coarse.reason}"
    scale = max(1.0, problem.sheet.length)
    resume = _resume_load(coarse, states, path, kappa, gravity)
    steps, snaps, rejected, note = (tuple(coarse.steps), tuple(coarse.snaps),
                                    coarse.rejected_steps, "")
    if resume is not None:
        done, info = _resume_fine(problem, cproblem, path, kappa, linear, newton_options,
                                  step_options, stats, report, coarse, states, *resume, scale,
                                  on_step, gravity)
        if done != "snapped":
            return done, info
        # the fine branch ended at the coarse fold: the sheet snaps there on the
        # fine mesh too, onto the branch the coarse path snapped to
        steps, snaps, rejected, note = info
    opts = replace(newton_options,
                   max_iterations=max(newton_options.max_iterations, FINISH_ITERATIONS))

    def finish(src, w_src, dst, lin, st):
        return _newton_from(src, w_src, dst, coarse.kappa, coarse.g, lin, opts, st,
                            scale * step_options.max_correction)

    res, w0 = finish(cproblem, coarse.w, problem, linear, stats)
    if not res.converged:
        # a coarse state too far from the fine equilibrium for Newton: through
        # a mesh between the two (its work counted with the coarse mesh's)
        h_mid = float(np.sqrt(cproblem.sheet_mesh.hmax * problem.sheet_mesh.hmax))
        why = f"fine Newton from the coarse state failed: {res.reason}"
        mid = build_problem(problem.sheet, h_mid, None, quadrature_order,
                            bool(problem.sheet_mesh.half), 0)
        rm, wm = finish(cproblem, coarse.w, mid, clinear, cstats)
        nu_m = mid.nu_dof
        if not rm.converged or np.abs(rm.w[:nu_m] - wm[:nu_m]).max() > 0.1 * scale:
            return None, f"{why}; on hmax {h_mid:.3g} too: {rm.reason or 'moved'}"
        res, _ = finish(mid, rm.w, problem, linear, stats)
        if not res.converged:
            return None, f"{why}; from hmax {h_mid:.3g} too: {res.reason}"
        steps += (("intermediate", 1.0, rm.iterations),)
    nu = problem.nu_dof
    moved = float(np.abs(res.w[:nu] - w0[:nu]).max())
    if moved > 0.1 * scale:
        return None, (f"fine Newton moved a node by {moved:.3g} from the coarse state "
                      f"(more than {0.1 * scale:.3g}: another branch)")
    # the load paths' end-state check: the same verdict as start="path" would give
    stable, k = end_state_verdict(problem, linear, res.w, stats)
    if stable is not True:
        what = "unknown" if stable is None else f"unstable ({k} negative eigenvalue(s))"
        return None, f"fine end state {what}"
    report(1.0)
    return _Reached(w=res.w, kappa=coarse.kappa, g=coarse.g,
                    steps=steps + (("fine", 1.0, res.iterations),),
                    snaps=snaps, rejected_steps=rejected,
                    stable=stable, negative_eigenvalues=k, resume=note), ""


def _resume_fine(problem, cproblem, path, kappa, linear, newton_options, step_options, stats,
                 report, coarse, states, index, lam_snap, why, scale, on_step, gravity):
    """The load path on ``problem`` resumed from the coarse state
    ``states[index]`` (at the load of ``coarse.steps[index]``), after a late
    coarse snap at ``lam_snap`` (both from :func:`_resume_load`).

    The coarse state is transferred and solved there by Newton (to the
    intermediate tolerance), then the fine path resumes
    (:func:`~skfem_sheet.continuation.follow_path` with ``resume``), first
    without snapping: its steps are not cut below ``StepOptions.snap_step``.
    If it reaches full load, the fine mesh holds the branch (no snap).  If its
    steps fall below ``snap_step`` within :data:`FOLD_SHIFT` of the coarse
    snap, the fine branch ends at the coarse fold: the sheet snaps on the fine
    mesh too (recorded at the last load the fine path held the branch), onto
    the branch the coarse path snapped to, so the caller finishes the coarse
    end state (a snap settle on the fine mesh costs about as much as its whole
    path).  Otherwise the fine path goes on from where it stopped, snapping as
    the load path does.

    Returns ``(outcome, "")`` or ``(None, why)`` as :func:`_coarse_to_fine`,
    or ``("snapped", (steps, snaps, rejected_steps, note))`` for the caller to
    finish the coarse end state with that history.
    """
    named = load_phases(path, kappa, gravity)
    phases, order = dict(named), [name for name, _ in named]
    last = order[-1]
    loose = replace(newton_options, rtol=1.0, utol=step_options.intermediate_utol,
                    max_iterations=max(newton_options.max_iterations, FINISH_ITERATIONS))
    # a transferred state can lie outside the fine Newton's basin although it is
    # near the fine branch (at hmax 0.2 -> 0.15, a/R 6: 0.049 from it, Newton
    # fails, while the coarse states one step before and after converge): then
    # from the coarse states before it, up to RESUME_TRIES in all
    failed, first = [], index
    for index in range(first, max(-1, first - RESUME_TRIES), -1):
        phase, lam, _ = coarse.steps[index]
        if phase != last:  # the end of the phase before: the start of the last one
            phase, lam = last, 0.0
        res, _ = _newton_from(cproblem, states[index], problem, *phases[phase](lam), linear,
                              loose, stats, scale * step_options.max_correction)
        if res.converged:
            break
        failed.append(f"at {phase} {lam:.3g}: {res.reason}")
        if phase != coarse.steps[index][0]:
            break  # no earlier state of the last phase
    where = f"{why}; resumed at {phase} {lam:.3g}"
    if failed:
        where += f" (fine Newton from the coarse state failed {'; '.join(failed)})"
    if not res.converged:
        return None, f"{why}: fine Newton from the coarse state failed {'; '.join(failed)}"
    frames = []  # passed on only if the resumed path succeeds (else the whole path runs)
    collect = None if on_step is None else (lambda *frame: frames.append(frame))
    before = tuple(x for x in coarse.snaps
                   if (order.index(x[0]), x[1]) <= (order.index(phase), lam))
    steps = tuple(coarse.steps[:index + 1]) + (("fine", lam, res.iterations),)
    rejected = coarse.rejected_steps
    # first without snapping: does the fine branch end near the coarse fold?
    no_snap = replace(step_options, min_step=max(step_options.min_step, step_options.snap_step),
                      snap_step=0.5 * min(step_options.min_step, step_options.snap_step))
    probe = follow_path(problem, path, kappa, linear, newton_options=newton_options,
                        step_options=no_snap, stats=stats, w0=res.w, resume=(phase, lam),
                        gravity=gravity,
                        progress=lambda f: report(0.9 + 0.1 * f), on_step=collect)
    steps += tuple(probe.steps)
    rejected += probe.rejected_steps
    rest = probe
    if not probe.converged:
        held = [x for x in probe.steps if x[0] == last]
        lam_end = held[-1][1] if held else lam
        # (not the end-state check at full load: the probe's branch ended short of it)
        stopped = lam_end < 1.0 and (probe.kappa, probe.g) == phases[last](lam_end)
        if stopped and abs(lam_end - lam_snap) <= FOLD_SHIFT:
            for frame in frames:
                on_step(*frame)
            k_end, g_end = phases[last](lam_end)
            note = (f"{where}; the fine branch ends at {last} {lam_end:.3g} (snapped onto the "
                    f"coarse path's branch)")
            return "snapped", (steps, before + ((last, lam_end, k_end, g_end),), rejected,
                               note)
        if not stopped:
            return None, f"{where}: the resumed fine path failed: {probe.reason}"
        # the fine branch ends away from the coarse fold: the load path goes on
        # from there, snapping as it does
        rest = follow_path(problem, path, kappa, linear, newton_options=newton_options,
                           step_options=step_options, stats=stats, w0=probe.w,
                           resume=(last, lam_end), gravity=gravity, progress=lambda f: report(0.9 + 0.1 * f),
                           on_step=collect)
        if not rest.converged:
            return None, f"{where}: the resumed fine path failed: {rest.reason}"
        steps += tuple(rest.steps)
        rejected += rest.rejected_steps
    for frame in frames:
        on_step(*frame)
    report(1.0)
    return _Reached(w=rest.w, kappa=rest.kappa, g=rest.g, steps=steps,
                    snaps=before + tuple(probe.snaps) + (() if rest is probe else
                                                         tuple(rest.snaps)),
                    rejected_steps=rejected, stable=rest.stable,
                    negative_eigenvalues=rest.negative_eigenvalues, resume=where,
                    own_frames=True), ""


def _branch(path, snaps):
    own, other = "curvature-dominated", "gravity-dominated"
    if path == "gravity-first":
        own, other = other, own
    # a path changes branch at most once (the followed branch ends at a fold
    # and the sheet snaps to the other); several recorded snaps are stages of it
    return other if len(snaps) else own
