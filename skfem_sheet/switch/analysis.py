"""How hard one sheet is to switch (:func:`switching`, :class:`Switching`): the
curve on the mesh ``curve_hmax``, the folds, the saddle and the drooped state
located again on ``hmax`` from the carried states (the curve traced on
``hmax`` itself where they do not converge); the switching forces and the
barriers ``Pi(saddle) - Pi(aloft)``, ``Pi(saddle) - Pi(drooped)``, in SI
where the sheet has its scales (``Sheet.si``).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from ..analyses.transfer import transfer
from ..build import BuildChain
from ..io import dumps_json, write_json
from ..params import ParameterError, Sheet, SIScale, check_range
from ..result import Result, SolveError
from ..solve import build_problem, solve
from ..states import SAME_TOL
from ..version import __version__
from .curve import ForceCurve
from .trace import CURVE_HMAX, FORCE_UNIT, Tracer, check_curve_args, force_curve


# -----------------------------------------------------------------------------
# the analysis of one sheet
# -----------------------------------------------------------------------------
@dataclass(frozen=True)
class Switching:
    """How hard it is to switch one sheet (:func:`switching`).

    Attributes
    ----------
    sheet : Sheet
    hmax : float
    bistable : bool
        Two stable states at F = 0 on one S, the saddle between them.
    states : str
        The verdict in words ("two states ..." or "one state: ...").
    force_down : float
        ``F_down < 0``: the push down (``rho g a^3``) at which the aloft
        state ends (its fold); NaN where there is none.
    force_up : float
        ``F_up > 0``: the pull up at which the drooped state ends; NaN where none.
    fold_down_deflection, fold_up_deflection : float
        d/a at those folds.
    barrier_down, barrier_up : float
        ``Pi(saddle) - Pi(aloft)``, ``Pi(saddle) - Pi(drooped)`` (``rho g a^4``).
    saddle_deflection, saddle_energy : float
        d/a and Pi of the saddle (the unstable state at F = 0).
    saddle_negative_eigenvalues : int or None
    aloft_deflection, aloft_energy, drooped_deflection, drooped_energy : float
    weight : float
        The sheet's weight, ``area x thickness`` (``rho g a^3``).
    shape : str
        The curve's shape (``"one S"``, or what it is instead).
    notes : tuple of str
    curve : ForceCurve
        The force-deflection curve (on its own mesh, ``curve.hmax``).
    work_down, work_up : float
        ``int F dw_tip`` from the aloft (drooped) state to the saddle: the
        barriers on the curve's mesh by the work identity.
    curve_barrier_down, curve_barrier_up : float
        The barriers on the curve's mesh, from its states' energies.
    si : SIScale or None
        The SI scales (then :meth:`summary` holds the SI values too).
    factorizations : int
        On the mesh ``hmax`` (the curve's and the solve's included).
    wall_time_s, solve_wall_time_s : float
        All of it, and the solve of the aloft state within it.
    problem : SheetProblem
        The discrete sheet on ``hmax`` (F = 0) of the states.
    saddle_state, aloft_state, drooped_state : ndarray or None
        Full dof vectors on ``problem``.
    """

    sheet: Sheet
    hmax: float
    bistable: bool
    states: str
    force_down: float
    force_up: float
    fold_down_deflection: float
    fold_up_deflection: float
    barrier_down: float
    barrier_up: float
    saddle_deflection: float
    saddle_energy: float
    saddle_negative_eigenvalues: object
    aloft_deflection: float
    aloft_energy: float
    drooped_deflection: float
    drooped_energy: float
    weight: float
    shape: str
    notes: tuple
    curve: ForceCurve = field(repr=False)
    work_down: float = math.nan
    work_up: float = math.nan
    curve_barrier_down: float = math.nan
    curve_barrier_up: float = math.nan
    si: object = None
    factorizations: int = 0
    wall_time_s: float = 0.0
    solve_wall_time_s: float = 0.0
    problem: object = field(default=None, repr=False)
    saddle_state: object = field(default=None, repr=False)
    aloft_state: object = field(default=None, repr=False)
    drooped_state: object = field(default=None, repr=False)

    def __repr__(self) -> str:
        s = self.sheet
        head = (f"Switching(L/a {s.length:g}, b/a {s.tip_width:g}, a/R {s.curvature:g}, "
                f"hmax {self.hmax:g}: ")
        if not self.bistable:
            return head + f"{self.states})"
        return head + (f"bistable, force_down {self.force_down:.4g} ({self._w(self.force_down)}"
                       f" of the weight), force_up {self.force_up:+.4g} "
                       f"({self._w(self.force_up)}), barrier_down {self.barrier_down:.4g}, "
                       f"barrier_up {self.barrier_up:.4g})")

    def _w(self, F) -> str:
        return f"{100 * F / self.weight:+.3g}%"

    def with_si(self, si: SIScale) -> Switching:
        """The same analysis reported in SI units too (``si``: the sheet's scales)."""
        if not isinstance(si, SIScale):
            raise ParameterError(f"si must be a SIScale, got {type(si).__name__}")
        return replace(self, si=si)

    def in_si(self) -> dict:
        """The forces in newtons, the barriers in joules, d in metres (``si`` needed)."""
        if self.si is None:
            raise ParameterError("in_si needs the sheet's SI scales: switching(..., si=...) or "
                                 "with_si(...)")
        f, e, a = self.si.force, self.si.energy, self.si.base_width
        return {"force_down_N": self.force_down * f, "force_up_N": self.force_up * f,
                "weight_N": self.weight * f,
                "barrier_down_J": self.barrier_down * e, "barrier_up_J": self.barrier_up * e,
                "saddle_deflection_m": self.saddle_deflection * a,
                "aloft_deflection_m": self.aloft_deflection * a,
                "drooped_deflection_m": self.drooped_deflection * a,
                "fold_down_deflection_m": self.fold_down_deflection * a,
                "fold_up_deflection_m": self.fold_up_deflection * a,
                "scales": self.si.to_json()}

    def summary(self) -> dict:
        """JSON-ready (the command line's ``--json``): the interface's names as keys."""
        out = {"sheet": self.sheet.to_dict(), "hmax": self.hmax, "bistable": self.bistable,
               "states": self.states, "force_down": self.force_down, "force_up": self.force_up,
               "fold_down_deflection": self.fold_down_deflection,
               "fold_up_deflection": self.fold_up_deflection,
               "barrier_down": self.barrier_down, "barrier_up": self.barrier_up,
               "saddle_deflection": self.saddle_deflection, "saddle_energy": self.saddle_energy,
               "saddle_negative_eigenvalues": self.saddle_negative_eigenvalues,
               "aloft_deflection": self.aloft_deflection, "aloft_energy": self.aloft_energy,
               "drooped_deflection": self.drooped_deflection,
               "drooped_energy": self.drooped_energy, "weight": self.weight,
               "force_down_per_weight": self.force_down / self.weight,
               "force_up_per_weight": self.force_up / self.weight,
               "shape": self.shape, "notes": list(self.notes),
               "work_down": self.work_down, "work_up": self.work_up,
               "curve_barrier_down": self.curve_barrier_down,
               "curve_barrier_up": self.curve_barrier_up,
               "curve": self.curve.summary(), "factorizations": self.factorizations,
               "wall_time_s": self.wall_time_s, "solve_wall_time_s": self.solve_wall_time_s,
               "units": {"force": "rho g a^3", "energy": "rho g a^4", "deflection": "a"},
               "version": __version__}
        if self.si is not None:
            out["si"] = self.in_si()
        return out

    def to_json(self) -> str:
        return dumps_json(self.summary())

    def write(self, filename) -> None:
        """Write :meth:`summary` as JSON (atomically)."""
        write_json(self.summary(), filename)

    def lines(self) -> list:
        """The analysis in words, one line each (``print(result)``)."""
        s = self.sheet
        out = [f"switching: L/a = {s.length:g}, b/a = {s.tip_width:g}, a/R = {s.curvature:g}, "
               f"h/a = {s.thickness:g}, E/(rho g a) = {s.modulus:g}, hmax {self.hmax:g} "
               f"(curve on hmax {self.curve.hmax:g})", f"  {self.states}"]
        si = self.in_si() if self.si is not None else None

        def force(name, F, d):
            if not np.isfinite(F):
                return
            line = (f"  {name} = {F:+.6g} rho g a^3 ({100 * F / self.weight:+.3g}% of the "
                    f"weight), d/a {d:.5f} at its fold")
            if si is not None:
                line += f"; {1e3 * F * self.si.force:+.4g} mN"
            out.append(line)

        force("force_down", self.force_down, self.fold_down_deflection)
        force("force_up", self.force_up, self.fold_up_deflection)
        if self.bistable:
            for name, e in (("barrier_down", self.barrier_down), ("barrier_up", self.barrier_up)):
                line = f"  {name} = {e:.6g} rho g a^4"
                if si is not None:
                    line += f" ({1e6 * e * self.si.energy:.4g} microjoules)"
                out.append(line)
            out.append(f"  saddle: d/a {self.saddle_deflection:.6f}, "
                       f"{self.saddle_negative_eigenvalues} negative eigenvalue(s); aloft d/a "
                       f"{self.aloft_deflection:.6f}, drooped d/a {self.drooped_deflection:.6f}")
            out.append(f"  work identity on hmax {self.curve.hmax:g}: int F dw_tip "
                       f"{self.work_down:.6g} / {self.work_up:.6g} against the barriers "
                       f"{self.curve_barrier_down:.6g} / {self.curve_barrier_up:.6g}")
        w = f"  the sheet's weight: {self.weight:.6g} rho g a^3"
        if si is not None:
            w += f" = {1e3 * self.weight * self.si.force:.4g} mN"
        out.append(w)
        out.append(f"  the curve: {self.shape}, {len(self.curve.points)} points; "
                   f"{self.factorizations} factorisations on hmax {self.hmax:g}, "
                   f"{self.wall_time_s:.1f} s")
        out += [f"  note: {n}" for n in self.notes]
        return out

    def __str__(self) -> str:
        return "\n".join(self.lines())

    def _repr_pretty_(self, p, cycle):
        p.text(repr(self) if cycle else str(self))


def _branch_of(result: Result) -> str:
    """The name of the state a solve ended on."""
    return result.branch


def _curve_mesh(hmax, curve_hmax):
    if curve_hmax is None:
        return max(float(hmax), CURVE_HMAX)
    return check_range("curve_hmax", curve_hmax, hmax, None,
                       hint="the curve is traced on hmax or a coarser mesh")


def switching(sheet: Sheet, hmax: float = 0.03, *, curve_hmax: float | None = None,
              layers=None, solver: str = "auto", symmetric: bool = True,
              max_force: float = 2.0, max_points: int = 400, si: SIScale | None = None,
              progress: bool = False, chain: BuildChain | None = None) -> Switching:
    """The switching forces and energy barriers of one sheet.

    The sheet is solved curvature-first, the force-deflection curve traced
    from that state (:func:`force_curve`, pushing down; pulling up if it
    ended drooped) on ``curve_hmax``; where that is coarser than ``hmax`` its
    folds, saddle and other state at F = 0 are located again on ``hmax``
    (where that fails, or the coarse curve is not one S, the curve is traced
    on ``hmax``).

    Parameters
    ----------
    sheet : Sheet
        With a tip face (``tip_width > 0``, or a planform whose cut ``x = L``
        remains).
    hmax : float
        The mesh of the answer.
    curve_hmax : float, optional
        The mesh the curve is traced on (default: ``hmax`` from 0.1 up, else
        :data:`CURVE_HMAX`); ``curve_hmax=hmax`` traces it on ``hmax``.
    layers, solver, symmetric
        As for :func:`~skfem_sheet.solve.solve` (``symmetric=False``: the
        whole sheet, whose curve can show asymmetric branch points).
    max_force : float
        The range of ``|F|`` traced, in units of the sheet's weight.
    max_points : int
        Most points per segment of the curve.
    si : SIScale, optional
        The sheet's SI scales (default ``sheet.si``, the scales of a sheet made
        by :meth:`~skfem_sheet.params.Sheet.from_si`):
        the summary then holds newtons and joules too.
    progress : bool
        A progress bar on stderr (F and d of the curve's points).
    chain : BuildChain, optional
        Keeps the meshes (the solve's and the curve's) for the next call.

    Returns
    -------
    Switching

    Raises
    ------
    ParameterError
        Bad input (the sheet has no tip face ...).
    SolveError
        The curvature-first solve did not reach full load.

    Examples
    --------
    >>> s = switching(Sheet(length=1.3, curvature=2.5), hmax=0.2)
    >>> s.bistable, s.force_down < 0 < s.force_up, s.barrier_down > 0
    (True, True, True)
    """
    if not isinstance(sheet, Sheet):
        raise ParameterError(f"sheet must be a skfem_sheet.Sheet, got {type(sheet).__name__}")
    hmax = check_range("hmax", hmax, 0, None, lo_open=True)
    trace_h = _curve_mesh(hmax, curve_hmax)
    max_force, _, _, max_points = check_curve_args(max_force, 0.01, 0.04, max_points)
    if si is None:
        si = sheet.si
    elif not isinstance(si, SIScale):
        raise ParameterError(f"si must be a SIScale or None, got {type(si).__name__}")
    if chain is not None and not isinstance(chain, BuildChain):
        raise ParameterError(f"chain must be a skfem_sheet.build.BuildChain or None, got "
                             f"{type(chain).__name__}")
    chain = chain if chain is not None else BuildChain(max_meshes=3)
    # the tip face, before anything is solved
    _ = build_problem(sheet, trace_h, None if trace_h != hmax else layers, 2, bool(symmetric),
                      chain=chain).tip_load
    t0 = time.perf_counter()
    bar = _Progress(sheet) if progress else None
    common = dict(solver=solver, max_force=max_force, max_points=max_points, progress=bar)
    try:
        r = solve(sheet, "curvature-first", hmax, layers=layers, solver=solver,
                  symmetric=symmetric, on_failure="return", chain=chain)
        if not r.converged:
            raise SolveError(f"the sheet could not be solved curvature-first: {r.message}", r)
        solve_time = time.perf_counter() - t0
        fine_work = r.factorizations
        direction = -1 if _branch_of(r) == "curvature-dominated" else 1
        notes, located, curve = [], None, None
        if trace_h > hmax:
            rc = solve(sheet, "curvature-first", trace_h, solver=solver, symmetric=symmetric,
                       on_failure="return", chain=chain)
            if rc.converged and _branch_of(rc) == _branch_of(r):
                curve = force_curve(rc.problem, rc.w, sheet.curvature, direction=direction,
                                    **common)
                if curve.shape == "one S":
                    located = _locate_on(r, curve, sheet.curvature, solver)
                    if located is None:
                        notes.append(f"the folds and states of the curve on hmax {trace_h:g} "
                                     f"could not all be located on hmax {hmax:g}: the curve "
                                     f"was traced on hmax {hmax:g}")
                else:
                    # not an S on the coarse mesh: is the sheet bistable on hmax?
                    rg = solve(sheet, "gravity-first", hmax, layers=layers, solver=solver,
                               symmetric=symmetric, on_failure="return", chain=chain)
                    fine_work += rg.factorizations
                    if rg.converged and _separation(r, rg) <= SAME_TOL:
                        located = _locate_on(r, curve, sheet.curvature, solver, partial=True)
                        notes.append(f"the curve on hmax {trace_h:g} is not one S "
                                     f"({curve.shape}), and on hmax {hmax:g} both load paths "
                                     f"reach one state")
                    else:
                        notes.append(f"the curve on hmax {trace_h:g} is not one S "
                                     f"({curve.shape}) but on hmax {hmax:g} the load paths "
                                     f"reach two states: the curve was traced on hmax "
                                     f"{hmax:g}")
            else:
                notes.append(f"on hmax {trace_h:g} the curvature-first solve "
                             + ("failed" if not rc.converged else
                                f"ended on the {_branch_of(rc)} state")
                             + f": the curve was traced on hmax {hmax:g}")
        if located is None:
            curve = force_curve(r.problem, r.w, sheet.curvature, direction=direction, **common)
            located = _from_curve(curve)
    finally:
        if bar is not None:
            bar.close()
    notes += located["notes"] + list(curve.notes)
    out = _assemble(sheet, hmax, r, curve, located, direction, notes, si)
    return replace(out, factorizations=fine_work + located["factorizations"],
                   wall_time_s=time.perf_counter() - t0, solve_wall_time_s=solve_time)


def _separation(a: Result, b: Result) -> float:
    """Largest distance between a node's deformed positions in two end states
    on one mesh (base widths; :data:`~skfem_sheet.states.SAME_TOL` tells one
    state from two)."""
    ua, ub = a.displacement, b.displacement
    if ua.shape != ub.shape:
        return math.inf
    return float(np.linalg.norm(ua - ub, axis=1).max())


class _Progress:
    def __init__(self, sheet):
        from tqdm.auto import tqdm

        self.bar = tqdm(desc=f"switching L={sheet.length:g} b={sheet.tip_width:g} "
                        f"a/R={sheet.curvature:g}", unit="pt", leave=False)

    def __call__(self, F, d):
        self.bar.update(1)
        self.bar.set_postfix_str(f"F {F:+.3g}, d/a {d:.3f}", refresh=True)

    def close(self):
        self.bar.close()


def _from_curve(curve: ForceCurve) -> dict:
    """The folds and states at F = 0 of a curve traced on the answer's mesh."""
    return {"folds": curve.folds, "saddle": curve.point("saddle"), "end": curve.point("end"),
            "start": curve.points[0], "states": curve.states, "notes": [],
            "factorizations": curve.factorizations}


def _locate_on(r: Result, curve: ForceCurve, curvature, solver, partial: bool = False):
    """The coarse curve's folds, saddle and end state carried to the mesh of
    the solve ``r`` and located there (the folds on the branch from the
    carried fold state and null vector, the states at F = 0 by Newton): the
    located points, or None where one fails or lands elsewhere (a fold on
    the other side of F = 0, a saddle without its one negative eigenvalue, an
    end state that is not stable).  ``partial``: the folds that fail are left
    out (with a note) instead."""
    fine = r.problem
    sheet = fine.sheet
    tr = Tracer(fine, curvature, 1.0, solver, FORCE_UNIT * sheet.area * sheet.thickness)
    P = tr.P
    coarse = curve.problem
    start = tr.at_zero(r.w[P.free])
    if start is None:
        return None
    out = {"start": tr.point(start[0], 0.0, start[1], "start"),
           "states": {"start": P.full(start[0], [0.0])}, "notes": []}
    folds = []
    for n, cp in enumerate(curve.folds, 1):
        name = f"fold {n}"
        w = transfer(coarse, curve.states[name], fine)
        vc = np.zeros(coarse.ndof)
        vc[coarse.free] = curve.null_vectors[name]
        v = transfer(coarse, vc, fine)[fine.free]
        fold = tr.fold(w[fine.free], cp.force, v)
        if fold is None or np.sign(fold.value) != np.sign(cp.force):
            if not partial:
                return None
            out["notes"].append(f"the fold at F = {cp.force:.6g} on hmax {curve.hmax:g} was "
                                f"not located on hmax {fine.sheet_mesh.hmax:g}")
            continue
        folds.append(tr.fold_point(fold))
        out["states"][name] = P.full(fold.u, fold.p)
    for kind, want in (("saddle", 1), ("end", 0)):
        if kind not in curve.states:
            continue
        w = transfer(coarse, curve.states[kind], fine)
        w[fine.clamp_dofs] = fine.clamp_values(curvature)
        found = tr.at_zero(w[fine.free])
        if found is None:
            return None
        cp = tr.point(found[0], 0.0, found[1], kind)
        if cp.negative_eigenvalues is not None and cp.negative_eigenvalues != want:
            return None
        out[kind] = cp
        out["states"][kind] = P.full(found[0], [0.0])
    out["folds"] = tuple(folds)
    out["factorizations"] = int(tr.counter.stats().factorizations)
    return out


def _assemble(sheet, hmax, r, curve, located, direction, notes, si) -> Switching:
    """The Switching of the located points (on the mesh ``hmax``) and the curve."""
    weight = float(sheet.area * sheet.thickness)
    start, saddle, end = located["start"], located.get("saddle"), located.get("end")
    folds = located["folds"]
    states = located["states"]
    bistable = bool(curve.shape == "one S" and saddle is not None and end is not None
                    and saddle.negative_eigenvalues == 1 and end.stable and start.stable)
    nan = math.nan
    fd = fu = fdd = fud = nan
    aloft, drooped = (start, end) if direction < 0 else (end, start)
    aloft_state, drooped_state = ((states.get("start"), states.get("end")) if direction < 0
                                  else (states.get("end"), states.get("start")))
    for f in folds:
        if f.force < 0 and not np.isfinite(fd):
            fd, fdd = f.force, f.deflection
        elif f.force > 0 and not np.isfinite(fu):
            fu, fud = f.force, f.deflection
    if bistable:
        what = (f"two states at F = 0 (bistable): aloft d/a {aloft.deflection:.5f}, drooped "
                f"d/a {drooped.deflection:.5f}, the saddle between them at d/a "
                f"{saddle.deflection:.5f}")
        bd = saddle.energy - aloft.energy
        bu = saddle.energy - drooped.energy
        sd, se, sk = saddle.deflection, saddle.energy, saddle.negative_eigenvalues
    else:
        name = _branch_of(r)
        word = "aloft" if name == "curvature-dominated" else "drooped"
        what = f"one state at F = 0: {name} ({word}), d/a {r.deflection:.5f}: no switching"
        if folds:
            what += (f"; under load the curve has {len(folds)} fold(s) in F ("
                     + ", ".join(f"{f.force:+.4g}" for f in folds) + f"): {curve.shape}")
        else:
            side = "pushed down" if direction < 0 else "pulled up"
            what += (f"; {side} to F = {curve.forces[np.argmax(np.abs(curve.forces))]:+.4g} "
                     f"({curve.reason or 'the end of the trace'}) without a fold")
        bd = bu = sd = se = nan
        sk = None
        if direction < 0:
            drooped = None
            drooped_state = None
        else:
            aloft = None
            aloft_state = None
    # the barriers on the curve's own mesh and the work along it
    wd = wu = cbd = cbu = nan
    cs, cz, ce = curve.points[0], curve.point("saddle"), curve.point("end")
    if cz is not None:
        first = "start"
        w1 = curve.work(first, "saddle")
        b1 = cz.energy - cs.energy
        if ce is not None:
            w2 = curve.work("end", "saddle")
            b2 = cz.energy - ce.energy
        else:
            w2 = b2 = nan
        (wd, cbd, wu, cbu) = (w1, b1, w2, b2) if direction < 0 else (w2, b2, w1, b1)
    return Switching(
        sheet=sheet, hmax=float(hmax), bistable=bistable, states=what,
        force_down=fd, force_up=fu, fold_down_deflection=fdd, fold_up_deflection=fud,
        barrier_down=bd, barrier_up=bu, saddle_deflection=sd, saddle_energy=se,
        saddle_negative_eigenvalues=sk,
        aloft_deflection=nan if aloft is None else aloft.deflection,
        aloft_energy=nan if aloft is None else aloft.energy,
        drooped_deflection=nan if drooped is None else drooped.deflection,
        drooped_energy=nan if drooped is None else drooped.energy,
        weight=weight, shape=curve.shape, notes=tuple(notes), curve=curve,
        work_down=wd, work_up=wu, curve_barrier_down=cbd, curve_barrier_up=cbu, si=si,
        problem=r.problem, saddle_state=states.get("saddle") if bistable else None,
        aloft_state=aloft_state, drooped_state=drooped_state)
