"""How :func:`~skfem_sheet.solve.solve` reaches full load on its mesh: the start strategies.

A strategy is a small frozen object with a ``reach(job)`` method that returns
a :class:`Reached` (the end state at full load and its history):

:class:`PathStart`
    the load path (:func:`~skfem_sheet.continuation.follow_path`) on the mesh
    of the solve;
:class:`CoarseStart`
    the load path on a coarse mesh, carried to the mesh of the solve by the
    rule that decides a snap there: every fold the coarse path located is
    transferred (state and null vector) and located again on the fine mesh
    (:func:`~skfem_sheet.engine.fold.fold_on_branch`).  A fine fold of the
    coarse one's kind (the load turns back) inside its phase: the fine sheet
    snaps there, and lands where the last coarse fold leading to it landed.
    A coarse fold the fine mesh has not nearby resumes the fine path from the
    coarse branch's last point before it; a fine fold beyond the phase's full
    load: the fine branch is finished at full load from the fold's quadratic
    normal form.  Without (more) folds the coarse end state is transferred
    and finished by Newton (or by :func:`~skfem_sheet.continuation.settle`
    where Newton leaves its basin), accepted by the load path's step rule and
    verified stable; otherwise the load path runs on the fine mesh (the
    record says why).  States are carried between the meshes as
    :func:`~skfem_sheet.analyses.transfer.transfer` says.

The coarse mesh is by default twice the mesh of the solve, at least 0.1 and
at most 0.2 (:meth:`CoarseStart.coarse_mesh`): hmax 0.1 for the paper's
0.03, 0.2 for a quick look at 0.1.  Where the coarse mesh has a coarse mesh
of its own by the same rule (hmax 0.05 and finer: 0.1, and below it 0.2),
the coarse path is itself reached that way: the path runs on 0.2, and its
folds and end state are carried to 0.1 and from there to the mesh of the
solve (``StartRecord.levels``; the record: ``docs/decisions.md``, "Nested
coarse starts").  A fold that the fine mesh has and the coarse one has not
is not found: the end state is then still the fine mesh's (Newton from the
coarse one, on the branch the snap lands on), but ``snaps`` lacks that snap
and ``branch`` is the path's own.  Near the cusp of a sheet's bistable range
the fold pair is thin; the load path's search at the minima of the load's
rate (:mod:`~skfem_sheet.engine.loadpath`) finds it on the coarse mesh too
(``benchmarks/results/robustness/stress_n100_seed1_hmax0.1_coarseauto.txt``).
``start="path"`` records every fold of its mesh.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field, replace
from typing import Callable, ClassVar

import numpy as np

from .analyses.observables import tip_deflection
from .analyses.transfer import TransferError, transfer
from .continuation import (
    Fold,
    PathOutcome,
    Snap,
    StepOptions,
    end_state_verdict,
    follow_path,
    landed_on_its_fold,
    load_phases,
    newton_tolerances,
    settle,
    snap_from_fold,
)
from .engine.corrector import correct, plain_linearization
from .engine.fold import fold_on_branch, locate_fold
from .engine.loadpath import ramp
from .engine.protocol import Counting, EngineFailure
from .linalg import make_linear_solver
from .newton import NewtonOptions, NewtonResult, Stats, newton
from .params import ParameterError, check_range
from .result import StartRecord
from .sheet_engine import LoadPhase, SheetLoadProblem

log = logging.getLogger(__name__)

__all__ = ["COARSEST_HMAX", "COARSE_HMAX", "STARTS", "CoarseStart", "Job", "PathStart", "Reached",
           "make_start"]

#: The names of the start strategies (``solve(start=...)``).
STARTS = ("path", "coarse")


@dataclass(frozen=True)
class Job:
    """What a start strategy is asked to do: the load path of one sheet on
    its mesh, to full load.

    Attributes
    ----------
    problem : SheetProblem
        The sheet on the mesh of the solve.
    path : str
    kappa, gravity : float
        Full load.
    linear : linear-solver back-end (on ``problem``)
    solver : str
        Its name (a coarse mesh gets a solver of its own).
    newton_options : NewtonOptions
    step_options : StepOptions
    stats : ~skfem_sheet.newton.Stats
        Counts the work on the mesh of the solve.
    build : callable(hmax) -> SheetProblem
        The sheet on another mesh (same layers rule, symmetry, quadrature).
    report : callable(fraction)
        Progress.
    on_step : callable(problem, w, kappa, g) or None
        Every accepted state on the mesh of the solve.
    """

    problem: object
    path: str
    kappa: float
    gravity: float
    linear: object
    solver: str
    newton_options: NewtonOptions
    step_options: StepOptions
    stats: Stats
    build: Callable
    report: Callable = field(default=lambda fraction: None)
    on_step: object = None


@dataclass(frozen=True)
class Reached:
    """How a strategy reached its end state: what the Result is made of."""

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
    record: StartRecord = field(default_factory=StartRecord)

    @classmethod
    def of_path(cls, out, record=None, steps=(), snaps=(), rejected=0):
        """The outcome of :func:`~skfem_sheet.continuation.follow_path`, after
        the history ``steps``, ``snaps``, ``rejected`` (of a coarse path)."""
        return cls(w=out.w, kappa=out.kappa, g=out.g, steps=tuple(steps) + tuple(out.steps),
                   snaps=tuple(snaps) + tuple(out.snaps),
                   rejected_steps=rejected + out.rejected_steps, stable=out.stable,
                   negative_eigenvalues=out.negative_eigenvalues, converged=out.converged,
                   reason=out.reason, record=record or StartRecord())


@dataclass(frozen=True)
class PathStart:
    """The load path on the mesh of the solve, from the reference state.

    Examples
    --------
    >>> PathStart().name
    'path'
    """

    name: ClassVar[str] = "path"

    def reach(self, job: Job, record: StartRecord | None = None) -> Reached:
        return Reached.of_path(_path(job), record)


#: The coarse path's mesh for fine meshes up to half as large (the automatic
#: choice of :class:`CoarseStart`; ``docs/decisions.md``, "Nested coarse starts").
COARSE_HMAX = 0.1

#: The coarsest mesh an automatic coarse path runs on: twice the mesh of the
#: solve from hmax 0.05 to 0.1.  Not coarser: at 0.2 fewer than three
#: elements span the half width, and the fold loads already move with the
#: mesh by 0.02-0.05 in L (``fold_curve_remesh_hmax0.2.txt``).
COARSEST_HMAX = 0.2


@dataclass(frozen=True)
class CoarseStart:
    """The load path on a coarse mesh, carried to the mesh of the solve
    by its located folds (see the module).

    Attributes
    ----------
    hmax : float or None
        Mesh size of the coarse path; None (the default) chooses it from the
        mesh of the solve (:meth:`coarse_mesh`): ``min_coarsening`` times as
        coarse, at least :data:`COARSE_HMAX` and at most :data:`COARSEST_HMAX`,
        and the coarse path is reached the same way where that mesh has a
        coarse mesh of its own (see the module).  An explicit mesh runs the
        path on it.
    min_coarsening : float
        The coarse path runs only where its mesh is at least this many times
        the mesh size of the solve: a factorisation costs about the square
        of the unknowns' ratio of the two meshes in 2D-like fill (the sheet is
        thin), so closer meshes make the coarse path cost as much as the path
        on the fine mesh (the load path runs there instead).

    Examples
    --------
    >>> CoarseStart().coarse_mesh(0.03), CoarseStart().coarse_mesh(0.1)
    (0.1, 0.2)
    >>> CoarseStart().usable_for(0.15)
    'coarse_hmax 0.2 is less than 2 times coarser than hmax 0.15: the path on hmax costs about as much'
    >>> CoarseStart(hmax=0.1).name, CoarseStart(hmax=0.1).usable_for(0.03)
    ('coarse', '')
    >>> CoarseStart().coarse_mesh(CoarseStart().coarse_mesh(0.03))   # the level below 0.1
    0.2
    """

    hmax: float | None = None
    min_coarsening: float = 2.0
    name: ClassVar[str] = "coarse"

    def __post_init__(self):
        if self.hmax is not None:
            check_range("coarse hmax", self.hmax, 0, None, lo_open=True)
        check_range("min_coarsening", self.min_coarsening, 1, None)

    def coarse_mesh(self, hmax: float) -> float:
        """The coarse path's mesh size for a solve on ``hmax``."""
        if self.hmax is not None:
            return float(self.hmax)
        return float(min(COARSEST_HMAX, max(COARSE_HMAX, self.min_coarsening * float(hmax))))

    def usable_for(self, hmax: float) -> str:
        """Why the coarse path does not run for the mesh size ``hmax`` ("" if it does)."""
        coarse = self.coarse_mesh(hmax)
        if coarse <= hmax:
            return f"coarse_hmax {coarse:g} is not coarser than hmax {hmax:g}"
        if coarse < self.min_coarsening * hmax * (1 - 1e-12):
            return (f"coarse_hmax {coarse:g} is less than {self.min_coarsening:g} times "
                    f"coarser than hmax {hmax:g}: the path on hmax costs about as much")
        return ""

    def reach(self, job: Job) -> Reached:
        try:
            out, record = self._carried_path(job, job.step_options.fold_tolerance / 100)
        except TransferError as err:
            # meshes that do not describe one outline (never two meshes of one
            # sheet): the path on the mesh of the solve, and the record says why
            hmax = float(job.problem.sheet_mesh.hmax) / 2 ** int(job.problem.sheet_mesh.refine)
            out, record = _path(job), StartRecord(self.name, self.coarse_mesh(hmax),
                                                  fallback=str(err))
        return Reached.of_path(out, record)

    def _carried_path(self, job: Job, coarse_fold_tolerance: float, finish: str = "fine"):
        """The load path on ``job``'s mesh by way of the coarse mesh's:
        ``(PathOutcome, StartRecord)``, its folds (with their states) on the
        mesh of ``job``, so that a finer mesh can carry them again.

        The coarse path is reached the same way where the automatic coarse
        mesh has a coarse mesh of its own (hmax 0.03: the path on 0.2, its
        folds and end state carried to 0.1 and from there to 0.03), its folds
        located to ``coarse_fold_tolerance`` on every coarse mesh.  ``finish``
        names the step that finishes the end state on this mesh."""
        fine = job.problem
        # the mesh's edge length: a nested refinement's base hmax halved refine times
        hmax = float(fine.sheet_mesh.hmax) / 2 ** int(fine.sheet_mesh.refine)
        chmax = self.coarse_mesh(hmax)
        why = self.usable_for(hmax)
        if why:
            return _path(job), StartRecord(self.name, chmax, fallback=why)
        cproblem = job.build(chmax)
        share = _coarse_share(cproblem.ndof, fine.ndof)
        clinear = make_linear_solver(job.solver)
        if getattr(clinear, "needs_layout", False):
            clinear.attach(cproblem.saddle_point_layout())
        cstats = Stats()
        # the coarse folds start the fine location: located to a hundredth of
        # the fold tolerance, their states lie a tenth as far along the null
        # vector from the fold as the fine tolerance allows (the offset goes
        # like the square root of the load's), so one section solve from the
        # carried state locates the fine fold (coarse factorisations cost
        # about 1/50 of fine ones at hmax 0.1 against 0.03)
        cjob = replace(job, problem=cproblem, linear=clinear, stats=cstats, on_step=None,
                       report=lambda f: job.report(share * f),
                       step_options=replace(job.step_options,
                                            fold_tolerance=coarse_fold_tolerance))
        levels = ()
        if self.hmax is None and not self.usable_for(chmax):
            coarse, inner = self._carried_path(cjob, coarse_fold_tolerance, finish="coarse")
            if inner.fallback:
                log.debug("the coarse path on hmax %g: %s", chmax, inner.fallback)
            levels = ({"hmax": inner.coarse_hmax,
                       "factorizations": inner.coarse_factorizations,
                       "newton_iterations": inner.coarse_newton_iterations,
                       "fallback": inner.fallback},) + inner.levels
        else:
            coarse = _path(cjob)

        def record(fallback="", folds=()):
            below = sum(level["factorizations"] for level in levels)
            newton_below = sum(level["newton_iterations"] for level in levels)
            return StartRecord(self.name, chmax, cstats.factorizations + below,
                               cstats.newton_iterations + newton_below, fallback, tuple(folds),
                               levels)

        def fall_back(why, folds=()):
            return _path(job), record(why, folds)

        def after_coarse(out, steps):
            """The fine path ``out``, which went on from a carried state, with
            the coarse path's history before it (``steps``) and the folds
            carried so far."""
            job.report(1.0)
            out.steps[:0] = steps
            out.snaps[:0] = [f.snap for f in folds]
            out.folds[:0] = folds
            out.rejected_steps += coarse.rejected_steps
            return out, record("", seen)

        if not coarse.converged:
            return fall_back(f"coarse path failed: {coarse.reason}")
        phases = load_phases(job.path, job.kappa, job.gravity)
        names = [name for name, _, _ in phases]
        sheet = SheetLoadProblem(fine, job.linear, job.stats, job.newton_options)
        tight = newton_tolerances(job.newton_options)
        scale = max(1.0, fine.sheet.length)
        folds, seen = [], []
        located_at = {}

        def located_on_fine(k):
            """Coarse fold ``k`` located on the fine mesh (once)."""
            if k not in located_at:
                fold = coarse.folds[k]
                phase = LoadPhase(sheet, *phases[names.index(fold.snap.phase)][1:])
                f0 = job.stats.factorizations
                located_at[k] = _fold_on_fine(cproblem, fold, sheet, phase, tight,
                                              job.step_options.fold_tolerance)
                log.debug("coarse fold at %.6g located on hmax %g at %s with %d "
                          "factorisations", fold.snap.load, hmax,
                          None if located_at[k] is None else located_at[k].value,
                          job.stats.factorizations - f0)
            return located_at[k]

        for k, fold in enumerate(coarse.folds):
            job.report(share + (1.0 - share) * k / (len(coarse.folds) + 1))
            name = fold.snap.phase
            iphase = names.index(name)
            phase = LoadPhase(sheet, *phases[iphase][1:])
            f0 = job.stats.factorizations
            located = located_on_fine(k)
            why = ""
            if located is None:
                why = (f"the coarse fold in the {name} phase at {fold.snap.load:.6g} was not "
                       f"located on hmax {hmax:g}")
            elif located.side != -1:
                # a load path's fold ends its branch: the load turns back there
                # (the branch's solutions lie below the fold load, side -1).  A
                # fold with its solutions above it is where a branch begins as
                # the load grows -- the lower fold of a fold pair that the fine
                # mesh has near the coarse fold -- and nothing snaps there
                why = (f"the coarse fold in the {name} phase at {fold.snap.load:.6g} was "
                       f"located on hmax {hmax:g} at {located.value:.6g}, a fold where the "
                       f"load turns up (a branch begins there), not where the sheet snaps")
            if why:
                # the fine mesh's fold is not near the coarse one: the fine
                # path from the coarse fold's state, an equilibrium of the fine
                # branch at that load (the branch goes on there on the fine
                # mesh), finds it
                out, more = _path_from_coarse_fold(cproblem, fold, sheet, phase, job)
                if out is None:
                    return fall_back(f"{why}, and {more}", seen)
                resumed = fold.before_load if fold.before is not None else fold.snap.load
                return after_coarse(out, [x for x in coarse.steps if (names.index(x[0]), x[1])
                                          <= (iphase, resumed)])
            lam = located.value
            if _same_fine_fold(located, name, folds, job.step_options.fold_tolerance):
                # two coarse folds close together, one on the fine mesh: the
                # sheet snapped from it already (the landing carried from the
                # first, or a snap of the fine mesh's own)
                seen.append({"phase": name, "coarse_load": fold.snap.load, "load": lam,
                             "snapped": False, "same_fine_fold": True})
                continue
            inside = lam <= 1.0
            seen.append({"phase": name, "coarse_load": fold.snap.load, "load": lam,
                         "snapped": inside})
            if inside:
                # the coarse folds after this one that lead to the same fine fold
                # (a snap in steps on the coarse mesh, one on the fine): the
                # sheet lands where the last of them landed
                last = k
                while last + 1 < len(coarse.folds) and \
                        coarse.folds[last + 1].snap.phase == name and \
                        located_on_fine(last + 1) is not None and \
                        _same_load(located_on_fine(last + 1).value, lam,
                                   job.step_options.fold_tolerance):
                    last += 1
                snapped = _fine_snap(cproblem, fold, sheet, phase, located, job,
                                     fold.snap.negative_eigenvalues, coarse.folds[last])
                if snapped is None:
                    return fall_back(f"the snap at the fold in the {name} phase at {lam:.6g} "
                                     f"failed on hmax {hmax:g}", seen)
                folds.append(snapped)
                log.debug("fine snap: %d factorisations with the location",
                          job.stats.factorizations - f0)
                continue
            # the fine fold lies beyond this phase's full load: no snap there; the
            # fine branch before the fold, at full load of the phase, and the load
            # path on from it on the fine mesh
            w = _before_fold(sheet, phase, located, tight)
            if w is None:
                return fall_back(f"the fine fold in the {name} phase lies beyond its full load "
                                 f"(at {lam:.6g}), but the state before it at full load did not "
                                 f"converge", seen)
            steps = tuple(x for x in coarse.steps if names.index(x[0]) < iphase) + (
                (finish, 1.0, 0),)
            last = iphase == len(phases) - 1
            out = _path(job, w0=w, resume=(name, 1.0) if last else (names[iphase + 1], 0.0),
                        on_step=None if last else job.on_step)
            if not out.converged:
                return fall_back(f"the fine path after the fold in the {name} phase failed: "
                                 f"{out.reason}", seen)
            return after_coarse(out, steps)
        # the coarse end state, finished on the fine mesh at full load
        job.report(share + (1.0 - share) * len(coarse.folds) / (len(coarse.folds) + 1))
        w0 = transfer(cproblem, coarse.w, fine)
        w0[fine.clamp_dofs] = fine.clamp_values(coarse.kappa)
        res = newton(fine, w0, coarse.g, job.linear, job.newton_options, job.stats)
        log.debug("fine Newton from the coarse end state: %s %s corrections %s", res.converged,
                  res.reason, np.round(res.corrections, 5).tolist())
        iterations = res.iterations
        if not res.converged:
            # outside Newton's basin: settled by the pseudo-transient, drawn to stable states, and
            # accepted by the same rule as Newton's (the distance from the
            # carried state: as Newton's, a check of the end state, which
            # also keeps it on the coarse path's branch where the fine sheet
            # is bistable, its states far apart)
            log.debug("fine Newton from the coarse end state failed (%s): settling", res.reason)
            pt, settled = settle(fine, w0, coarse.g, job.linear, job.newton_options,
                                 job.step_options, job.stats)
            why = pt.reason if settled is None else settled.reason
            if settled is not None and settled.converged:
                moved = float(np.abs(settled.w[:fine.nu_dof] - w0[:fine.nu_dof]).max())
                why = "" if not job.step_options.rule(scale).rejects(moved) else \
                    f"it settled {moved:.3g} away (another branch)"
            if not why:
                res = settled
                iterations += pt.iterations + settled.iterations
            elif folds:
                # a snap was carried: the fine sheet is on its landing state at
                # the last fold's load, and the load path goes on from there on
                # the fine mesh
                log.debug("the settle from the coarse end state failed (%s): the fine path "
                          "from the last landing", why)
                last = folds[-1]
                ilast = names.index(last.snap.phase)
                out = _path(job, w0=last.landing, resume=(last.snap.phase, last.snap.load))
                if not out.converged:
                    return fall_back(f"fine Newton from the coarse end state failed after a "
                                     f"carried snap ({res.reason}), and so did the settle "
                                     f"({why}) and the fine path from the landing: "
                                     f"{out.reason}", seen)
                return after_coarse(out, [x for x in coarse.steps if (names.index(x[0]), x[1])
                                          <= (ilast, last.snap.load)])
            else:
                return fall_back(f"fine Newton from the coarse end state failed, and so did "
                                 f"the settle from it: {why}", seen)
        moved = float(np.abs(res.w[:fine.nu_dof] - w0[:fine.nu_dof]).max())
        if job.step_options.rule(scale).rejects(moved):
            return fall_back(f"fine Newton moved {moved:.3g} from the coarse end state, more "
                             f"than four times the load path's nominal corrector distance "
                             f"(another branch)", seen)
        stable, k = end_state_verdict(fine, job.linear, res.w, job.stats)
        if stable is not True:
            what = "unknown" if stable is None else f"unstable ({k} negative eigenvalue(s))"
            return fall_back(f"fine end state {what}", seen)
        if job.on_step is not None:
            job.on_step(fine, res.w, coarse.kappa, coarse.g)
        job.report(1.0)
        out = PathOutcome(w=res.w, converged=True, kappa=coarse.kappa, g=coarse.g,
                          steps=list(coarse.steps) + [(finish, 1.0, iterations)],
                          rejected_steps=coarse.rejected_steps,
                          snaps=[f.snap for f in folds], folds=folds, stable=stable,
                          negative_eigenvalues=k)
        return out, record("", seen)


def _path(job: Job, w0=None, resume=None, on_step=...):
    """:func:`~skfem_sheet.continuation.follow_path` on ``job``'s mesh
    (from ``w0`` at ``resume``, see there)."""
    return follow_path(job.problem, job.path, job.kappa, job.linear,
                       newton_options=job.newton_options, step_options=job.step_options,
                       stats=job.stats, progress=job.report if w0 is None else None,
                       on_step=job.on_step if on_step is ... else on_step,
                       w0=w0, resume=resume, gravity=job.gravity)


def _coarse_share(n_coarse: int, n_fine: int) -> float:
    """The coarse path's share of a coarse start's work, for the progress bar
    only: a factorisation costs about ``n^1.5`` (2D-like fill of a thin sheet),
    the coarse path takes some 30 factorisations and the fine mesh some 6
    (the solve sample's medians: 35 and 4, with the fine mesh's snaps 8)."""
    c, f = 30.0 * n_coarse**1.5, 6.0 * n_fine**1.5
    return c / (c + f)


def make_start(start, coarse_hmax: float | None = None):
    """The strategy of ``solve(start=..., coarse_hmax=...)``: a strategy object
    as it is, or one of the names :data:`STARTS` (``coarse_hmax`` None: the
    coarse mesh chosen from the solve's, :meth:`CoarseStart.coarse_mesh`).

    Examples
    --------
    >>> make_start("coarse", 0.12)
    CoarseStart(hmax=0.12, min_coarsening=2.0)
    >>> make_start("coarse")
    CoarseStart(hmax=None, min_coarsening=2.0)
    >>> make_start(PathStart())
    PathStart()
    """
    if isinstance(start, (PathStart, CoarseStart)):
        return start
    if start == "path":
        return PathStart()
    if start == "coarse":
        return CoarseStart(hmax=None if coarse_hmax is None else
                           check_range("coarse_hmax", coarse_hmax, 0, None, lo_open=True))
    raise ParameterError(f"start must be one of {', '.join(STARTS)} or a start strategy "
                         f"(PathStart, CoarseStart), got {start!r}")


# -- the folds of a coarse path on the fine mesh -------------------------------------
def _carried(cproblem, fold, fine):
    """The coarse fold's state and null vector on ``fine``: ``(w, v_free)``."""
    w = transfer(cproblem, fold.w, fine)
    vc = np.zeros(cproblem.ndof)
    vc[cproblem.free] = fold.v
    v = transfer(cproblem, vc, fine)[fine.free]
    return w, v


def _fold_on_fine(cproblem, fold, sheet, phase, tol, ptol):
    """The coarse ``fold`` located on the fine mesh of ``sheet``, its load to
    ``ptol`` (FoldPoint or None)."""
    fine = sheet.problem
    w, v = _carried(cproblem, fold, fine)
    u = w[fine.free]
    counter = Counting(phase)
    p = np.array([fold.snap.load])
    try:
        # on the branch first, the cheaper of the two located folds
        # (docs/decisions.md, "A carried fold is located on the branch")
        located, _ = fold_on_branch(counter, u, p, 0, v, tol=tol, ptol=ptol)
        if located is None:
            located, _ = locate_fold(counter, u, p, 0, v0=v, tol=tol, approach=8)
    except EngineFailure:
        return None
    return located


def _fine_snap(cproblem, fold, sheet, phase, located, job, crossing, landed=None):
    """The snap at the fine fold ``located``: landing on the coarse path's
    landing state (of the coarse fold ``landed``, default ``fold``) carried
    over and solved at the fine fold load (else a snap settle on the fine
    mesh): the Fold (its Snap record, the fold state and null vector on the
    fine mesh, the landed state), or None."""
    fine = sheet.problem
    landed = fold if landed is None else landed
    kappa, g = phase.loads(located.p)
    w = transfer(cproblem, landed.landing, fine)
    w[fine.clamp_dofs] = fine.clamp_values(kappa)
    # a point on the way, solved like every point of the load path (to a
    # tenth of the nominal corrector distance, StepOptions.intermediate_utol)
    scale = max(1.0, fine.sheet.length)
    # by exact Newton: from a carried state one step or two, the last
    # factorisation the Hessian, whose inertia verifies the landing (MIP
    # Newton would factorise the Hessian once more for it)
    loose = replace(job.newton_options, rtol=1.0, linearization="exact",
                    utol=job.step_options.intermediate_utol(scale))
    res = newton(fine, w, g, job.linear, loose, job.stats)
    if not res.converged and landed.snap.load != located.value:
        res = _landing_followed_to_fine_load(cproblem, landed, phase, located.value, job, loose)
    w_fold = sheet.full(located.u, (kappa, g))
    landing = None
    if res.converged and not landed_on_its_fold(res.w, w_fold, fine.nu_dof, loose.utol):
        # (a carried landing that Newton takes back to the fold state is no
        # landing: the fine mesh has no stable state there, the coarse one's
        # was a step of a snap in two that the fine mesh makes in one)
        stable, _ = end_state_verdict(fine, job.linear, res.w, job.stats)
        if stable is not False:
            landing = res.w
    if landing is None:
        log.debug("the carried landing at %.6g: %s", located.value,
                  res.reason or "back at the fold, or unstable")
        found, _, _ = snap_from_fold(sheet, phase, fold.snap.phase,
                                     replace(located, crossing=crossing),
                                     newton_options=job.newton_options,
                                     step_options=job.step_options,
                                     negative_eigenvalues=crossing)
        return found
    v = np.asarray(located.v, dtype=float)
    v = v / float(np.abs(v[fine.free < fine.nu_dof]).max())
    snap = Snap(fold.snap.phase, float(located.value), kappa, g, tip_deflection(fine, w_fold),
                tip_deflection(fine, landing), tuple(crossing), float(fine.sheet_mesh.hmax))
    before = None
    if fold.before is not None:  # for a finer level: the coarse branch's point, carried
        before = transfer(cproblem, fold.before, fine)
        before[fine.clamp_dofs] = fine.clamp_values(phase.loads([fold.before_load])[0])
    return Fold(snap, w_fold, v, landing, before, fold.before_load)


def _landing_followed_to_fine_load(cproblem, fold, phase, lam, job, loose):
    """The coarse landing carried to the fine mesh at the coarse fold's load
    (where it is an equilibrium of the coarse sheet, so Newton from it
    converges on the fine one) and followed along its branch to the fine fold
    load ``lam`` by the load path's driver (where the fold loads of the two
    meshes differ by more than Newton's reach on a steep landing branch): a
    NewtonResult (full dofs), not converged where the branch does not reach
    ``lam`` (it turns before it: no landing there)."""
    fine = phase.sheet.problem
    exact = replace(job.newton_options, linearization="exact")
    sheet = SheetLoadProblem(fine, job.linear, job.stats, exact)
    lam_c = float(fold.snap.load)
    kappa, g = phase.loads([lam_c])
    w = transfer(cproblem, fold.landing, fine)
    w[fine.clamp_dofs] = fine.clamp_values(kappa)
    res = newton(fine, w, g, job.linear, loose, job.stats)
    if not res.converged:
        return res
    counter = Counting(LoadPhase(sheet, phase.start, phase.start + phase.rate))
    scale = max(1.0, fine.sheet.length)
    tol = newton_tolerances(job.newton_options, job.step_options.intermediate_utol(scale))
    before = counter.stats()
    branch = ramp(counter, res.w[fine.free], [lam_c], "lam", float(lam),
                  rule=job.step_options.rule(scale), tol=tol, end_tol=tol)
    job.stats.newton_iterations += (counter.stats() - before).newton_iterations
    log.debug("the carried landing followed from %.6g to %.6g: %s", lam_c, lam,
              "reached" if branch.completed else branch.reason)
    if not branch.completed:
        return NewtonResult(res.w, False, res.iterations, f"its branch: {branch.reason}")
    return NewtonResult(sheet.full(branch.points[-1].u, phase.loads([lam])), True,
                        res.iterations)


def _same_fine_fold(located, phase_name, folds, ptol) -> bool:
    """Whether the fine fold ``located`` is the one the sheet last snapped
    from on the fine mesh (the same phase, the load within the two locations'
    tolerance ``ptol`` each): a fold that two coarse folds close together lead
    to is snapped from once."""
    if not folds:
        return False
    last = folds[-1].snap
    return last.phase == phase_name and _same_load(located.value, last.load, ptol)


def _same_load(a, b, ptol) -> bool:
    """Whether two fold loads located to ``ptol`` each are one fold's."""
    return abs(a - b) <= 2.0 * ptol * max(1.0, abs(b))


def _path_from_coarse_fold(cproblem, fold, sheet, phase, job):
    """The load path on the fine mesh from the coarse branch's last point
    before the fold (:attr:`~skfem_sheet.continuation.Fold.before`; the fold
    state where it is not known): the state carried over and solved by
    Newton at its load, accepted as a point of the branch by the load path's
    step rule (its distance from the carried state) and stable, then the path
    from there to full load, which locates the fine mesh's fold of that
    branch, where the fine mesh has it.  (At the coarse fold itself a fine
    mesh whose fold lies further on has two equilibria near the fold state,
    the stable branch and the unstable one it turns into.)
    ``(PathOutcome, "")`` or ``(None, why not)``."""
    fine = sheet.problem
    state, lam = ((fold.before, fold.before_load) if fold.before is not None
                  else (fold.w, fold.snap.load))
    kappa, g = phase.loads([lam])
    w0 = transfer(cproblem, state, fine)
    w0[fine.clamp_dofs] = fine.clamp_values(kappa)
    res = newton(fine, w0, g, job.linear, job.newton_options, job.stats)
    if not res.converged:
        return None, f"Newton from its state on the fine mesh failed ({res.reason})"
    moved = float(np.abs(res.w[:fine.nu_dof] - w0[:fine.nu_dof]).max())
    if job.step_options.rule(max(1.0, fine.sheet.length)).rejects(moved):
        return None, (f"Newton from its state on the fine mesh moved {moved:.3g} (another "
                      f"branch)")
    stable, k = end_state_verdict(fine, job.linear, res.w, job.stats)
    if stable is False:
        return None, f"its state on the fine mesh is unstable ({k} negative eigenvalue(s))"
    out = _path(job, w0=res.w, resume=(fold.snap.phase, lam))
    if not out.converged:
        return None, f"the fine path from its state failed: {out.reason}"
    return out, ""


def _before_fold(sheet, phase, fold, tol):
    """The equilibrium at full load of ``phase`` (``lam = 1``) on the branch
    before the fold ``fold`` at ``lam* > 1``: predicted from the fold's normal
    form ``lam - lam* = c s^2`` along its null vector ``v`` (``|c| = |a / (2 v .
    R_lam)|``, ``c < 0``: the fold's branch lies below it, ``fold.side``) on
    the stable side (``a s > 0``), solved by Newton; the full dof vector, or
    None."""
    counter = Counting(phase)
    u, p, v = fold.u, fold.p, fold.v
    r_lam = counter.dresidual(u, p, 0)
    vr = float(v @ r_lam)
    if fold.a == 0 or vr == 0 or fold.side != -1:
        return None
    # the branch lies below the fold load (side -1, from the branch's own
    # curvature in the load): c < 0, its size from the normal form
    c = -abs(fold.a / (2.0 * vr))
    s = np.sign(fold.a) * np.sqrt((1.0 - fold.value) / c)
    res = correct(counter, u + s * v, np.array([1.0]), plain_linearization(counter), tol)
    if not res.converged:
        return None
    return sheet.full(res.u, phase.loads([1.0]))

