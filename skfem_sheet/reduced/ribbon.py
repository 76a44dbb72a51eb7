"""Ribbon-like model: large longitudinal rotations plus transverse curvature c(s).

Supplement, section "Reduced-order theory: large plate rotations".  The sheet
is described by the slope phi(s) of its cross-sectional centre of mass and the
transverse curvature c(s) of the shallow-cylinder ansatz (eq. wansatz).

What is solved
--------------
Instead of the printed Euler--Lagrange system (which carries typos, see
ERRATA.md), the *reduced energy* E[c, Phi] is discretised and minimised:

    E = int_0^L e(c, c', c'', Phi', phi) ds,
    Phi = phi - (c p^2)'/4!   (slope of the line t = 0),

with e from inserting the ansatz strains (eqs. strainansatz, bendstrainansatz,
verified symbolically: E_tt = E_st = 0 and the printed E_ss is exact, tapering
included) into eq. (asymenergy) and integrating over t exactly (see
:mod:`._ribbon_kernels`).  Its stationarity conditions are the paper's
(phODE) and the fourth-order equation for c with the natural conditions at
s = L, in their corrected form; none of the printed equations is used directly.
Clamping (eq. cclamp): c(0) = 1/R, c'(0) = 0, Phi(0) = 0, hence
phi(0) = (c p^2)'(0)/4! = p(0) p'(0)/(12 R), non-zero for tapered sheets
(ERRATA).  Unknowns are cubic Hermite elements on a fixed grid in S = s/L;
the stationary point is found by Newton's method with a line search on the
energy, so every converged state is a local minimum (stable) and a state that
ceases to exist (fold) is left for the other branch -- the physical jump.

Departures from the printed text
--------------------------------
- The printed ODEs (supplement eqs. 50-52) are not implemented: the first
  carries a spurious trailing double prime and the second's right-hand side
  inherits it (ERRATA).  Their corrected content, and the natural conditions
  at s = L, are the weak stationarity conditions of the discrete energy.  The
  t-moments used agree with the printed M^0_ss, M^2_ss = D p^5 c''/6!,
  M^1_st, M^0_tt, T^2_ss and T^4_ss (the moment integrals run over
  [-p/2, p/2], ERRATA).
- Only the leading-order clamping conditions (eq. cclamp) enter, so the typo
  in the clamp's e_2 term (R sin(t/R), ERRATA) is immaterial.
- Gravity acts on the centre of mass: rho g h int p e_3.r ds =
  rho g h int I(s) sin phi ds (eq. asymenergy); the deflection of the line
  t = 0 then adds w(L,0) cos phi(L) - w(0,0) cos phi(0).
- With c free and a flat clamp, Poisson coupling produces a small c, so the
  model equals the heavy elastica only with ``impose_flat=True`` (ERRATA); see
  the next section.

Flat clamp: c free is softer than the heavy elastica
----------------------------------------------------
At a/R = 0 the heavy elastica (eq. phODE2, plate modulus D) is the wide-plate
limit; the ribbon model with c free is softer, through the Poisson coupling
(c ~ -nu Phi', Searle's parameter beta = p^2 |Phi'|/h) and, for p' != 0, the
taper's coupling of c to phi'.  This is the model's physics, not a
discretisation error, and the 3D solver deviates from the elastica in the
same direction and by more (``docs/decisions.md``, "The ribbon model at a
flat clamp"; ``benchmarks/results/accuracy/ribbon_vs_elastica.txt``).

Sign convention: phi < 0 when the sheet droops; the deflection

    d = -[ int_0^L sin phi ds + w(L,0) cos phi(L) - w(0,0) cos phi(0) ],
    w(s, 0) = -c(s) p(s)^2 / 4!,

is reported positive downward.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from skfem_sheet.engine import sweep
from skfem_sheet.params import ParameterError, Sheet, check_range
from skfem_sheet.reduced._common import POISSON_RATIO, as_sheet, weight_per_area
from skfem_sheet.reduced._ribbon_fem import (
    EnergyProblem,
    descent_tolerances,
    energy_descent,
    make_mesh,
    make_operators,
    outcome,
)
from skfem_sheet.reduced._ribbon_kernels import energy_terms as _energy_term_densities

__all__ = [
    "ContinuationResult",
    "RibbonResult",
    "detect_jumps",
    "ribbon",
    "ribbon_continuation",
    "ribbon_energy_terms",
]

DEFAULT_ELEMENTS = 24
_BRANCHES = ("curvature", "gravity")
_DIRECTIONS = ("increasing", "decreasing")


@dataclass(frozen=True)
class RibbonResult:
    """Equilibrium of the ribbon model at one length.

    Attributes
    ----------
    length : float
        L/a.
    deflection : float
        Tip drop of the centre line t = 0, positive downward.
    converged : bool
        Newton converged to a stationary point.
    stable : bool
        The Hessian there is positive definite (a local energy minimum).
    iterations : int
        Newton iterations used.
    s, c, Phi, phi : ndarray
        Nodal arclength, transverse curvature, slope of t = 0 and of the centre line.
    state : ndarray
        Dof vector on the S = s/L grid (use as ``initial`` of the next solve).
    """

    length: float
    deflection: float
    converged: bool
    stable: bool
    iterations: int
    s: np.ndarray = field(repr=False)
    c: np.ndarray = field(repr=False)
    Phi: np.ndarray = field(repr=False)
    phi: np.ndarray = field(repr=False)
    state: np.ndarray = field(repr=False)


@dataclass(frozen=True)
class ContinuationResult:
    """A branch traced by :func:`ribbon_continuation` (arrays in continuation order).

    Attributes
    ----------
    lengths, deflection : ndarray
        L/a and d/a (positive downward).
    converged, stable, jumped : ndarray of bool
        Newton converged; local minimum; a discontinuity (branch switch) lies
        between this length and the previous one.
    direction : str
        ``"increasing"`` or ``"decreasing"``.
    results : tuple of RibbonResult
    jump_at : ndarray
        Located jump length at jumped points, NaN elsewhere.
    """

    lengths: np.ndarray
    deflection: np.ndarray
    converged: np.ndarray
    stable: np.ndarray
    jumped: np.ndarray
    direction: str
    results: tuple = field(repr=False)
    jump_at: np.ndarray = field(repr=False, default=None)

    @property
    def jump_lengths(self):
        """Lengths where the branch jumped (located within 1/64 of the grid step)."""
        return self.jump_at[self.jumped]


# -- pure helpers ------------------------------------------------------------------
def _free_mask(n_nodes: int, impose_flat: bool):
    """Free dofs: clamp fixes c, c_S, Phi at node 0; c == 0 fixes all c dofs."""
    free = np.ones(4 * n_nodes, dtype=bool)
    free[[0, 1, 2]] = False
    if impose_flat:
        free[0::4] = False
        free[1::4] = False
    return free


def _clamped_state(n_nodes: int, kappa: float, impose_flat: bool):
    """Initial state c = 1/R, Phi = 0 (c = 0 if flat is imposed)."""
    x = np.zeros(4 * n_nodes)
    if not impose_flat:
        x[0::4] = kappa
    return x


def _planform_profile(sheet):
    """``s -> (p, dp/ds, I)`` of a planform sheet (None for the trapezoid)."""
    if sheet.planform is None:
        return None

    def profile(s):
        s = np.asarray(s, dtype=float)
        return (np.asarray(sheet.width(s), dtype=float),
                np.asarray(sheet.width_slope(s), dtype=float),
                np.asarray(sheet.width_integral(s), dtype=float))
    return profile


def _nodal_fields(x, S, L, b, profile=None):
    """Nodal s, c, Phi, phi from the dof vector (phi = Phi + (c p^2)'/4!)."""
    c, cS, Phi = x[0::4], x[1::4], x[2::4]
    if profile is None:
        p = 1.0 + (b - 1.0) * S
        dp = (b - 1.0) / L
    else:
        p, dp, _ = profile(L * S)
    phi = Phi + (cS / L * p**2 + 2.0 * c * p * dp) / 24.0
    return L * S, c, Phi, phi


def _deflection(ops, x, S, L, b, profile=None):
    """d = -[int sin phi + w(L,0) cos phi(L) - w(0,0) cos phi(0)], w(s,0) = -c p^2/4!."""
    q = np.einsum("eqjk,ek->eqj", ops.B, x[ops.dofs])
    rise = float(np.sum(ops.weight * np.sin(q[..., 4])))
    _, c, _, phi = _nodal_fields(x, S, L, b, profile)
    pL = b if profile is None else float(profile(np.array([L]))[0][0])
    wL, w0 = -c[-1] * pL**2 / 24.0, -c[0] / 24.0
    return -(rise + wL * np.cos(phi[-1]) - w0 * np.cos(phi[0]))


def _moduli(sheet: Sheet):
    return sheet.stretching_modulus, sheet.bending_modulus, POISSON_RATIO


class RibbonProblem(EnergyProblem):
    """The ribbon model of a sheet as an engine problem in ``p = (L, a/R, g)``.

    ``g`` scales gravity (the load ramps); the state is the free dofs of the
    dof vector on the S = s/L grid (:func:`_free_mask`), the clamp values
    ``c(0) = a/R`` (0 with ``impose_flat``), ``c'(0) = Phi(0) = 0``.  Its
    corrector is Newton's method with a line search on the energy
    (:func:`skfem_sheet.reduced._ribbon_fem.energy_descent`), its
    continuations sweeps through prescribed values
    (:func:`skfem_sheet.engine.sweep`).
    """

    parameter_names = ("L", "a/R", "g")

    def __init__(self, template, mesh, impose_flat):
        super().__init__(_free_mask(mesh.n_elements + 1, impose_flat))
        self.template, self.mesh, self.impose_flat = template, mesh, bool(impose_flat)
        self._cache = {}

    def sheet(self, p):
        return self.template.replace(length=float(p[0]), curvature=float(p[1]))

    def operators(self, p):
        key = (float(p[0]), float(p[2]))
        ops = self._cache.get(key)
        if ops is None:
            if len(self._cache) > 8:
                self._cache.clear()
            sheet = self.template.replace(length=key[0])
            Y, D, nu = _moduli(sheet)
            ops = self._cache[key] = make_operators(
                self.mesh, sheet.extent, sheet.tip_width, weight_per_area(sheet), Y, D, nu,
                key[1], _planform_profile(sheet))
        return ops

    def fixed(self, p):
        x = np.zeros(4 * (self.mesh.n_elements + 1))
        if not self.impose_flat:
            x[0] = float(p[1])
        return x

    def result(self, res) -> RibbonResult:
        """The :class:`RibbonResult` of a corrector result."""
        sheet = self.template.replace(length=float(res.p[0]))
        x, conv, stable, its = outcome(self, res)
        return _result(sheet, self.mesh, self.operators(res.p), x, conv, stable, its)


def _params(sheet, gravity_scale=1.0):
    return np.array([sheet.length, sheet.curvature, gravity_scale])


def _sweep(P, x0, p0, param, values, revise=None):
    """:func:`skfem_sheet.engine.sweep` of ``P`` from the dof vector ``x0``."""
    return sweep(P, np.asarray(x0, dtype=float)[P.free], p0, param, values,
                 tol=descent_tolerances(), linearization=energy_descent, revise=revise)


def _result(sheet, mesh, ops, x, conv, stable, its):
    S = mesh.S_nodes
    L, b, prof = sheet.extent, sheet.tip_width, _planform_profile(sheet)
    s, c, Phi, phi = _nodal_fields(x, S, L, b, prof)
    d = _deflection(ops, x, S, L, b, prof)
    ok = bool(conv and np.isfinite(d))
    return RibbonResult(sheet.length, float(d), ok, bool(stable), int(its), s, c, Phi, phi, x)


def _gravity_first(sheet, mesh, impose_flat, n_ramp=10):
    """Load first, then clamp curvature (the paper's FE protocol for the gravity branch).

    The hanging sheet is solved with a flat clamp (gravity ramped in four
    steps), then the clamp curvature is raised to 1/R in ``n_ramp`` steps,
    each starting from the previous state: two sweeps.
    """
    flat = RibbonProblem(sheet, mesh, True)
    hang = _sweep(flat, _clamped_state(mesh.n_elements + 1, 0.0, True), _params(sheet), "g",
                  (0.25, 0.5, 0.75, 1.0))
    x = flat.full(hang[-1].u, hang[-1].p)
    P = RibbonProblem(sheet, mesh, impose_flat)
    if impose_flat or sheet.curvature == 0.0:
        return P.result(_sweep(P, x, _params(sheet), "g", (1.0,))[0])
    ramp = sheet.curvature * np.arange(1, n_ramp + 1) / n_ramp
    return P.result(_sweep(P, x, _params(sheet.replace(curvature=ramp[0])), "a/R", ramp)[-1])


def _validate_common(branch, n_elements):
    if branch not in _BRANCHES:
        raise ParameterError(f"branch must be one of {_BRANCHES}, got {branch!r}")
    n = int(check_range("n_elements", n_elements, 4, 400))
    if n != n_elements:
        raise ParameterError(f"n_elements must be an integer in [4, 400], got {n_elements!r}")
    return n


def ribbon(sheet, branch: str = "curvature", impose_flat: bool = False,
           n_elements: int = DEFAULT_ELEMENTS, initial=None) -> RibbonResult:
    """Solve the ribbon model at one length (supplement, eqs. 50-52 via the energy).

    Parameters
    ----------
    sheet : Sheet
        Sheet parameters (length, tip width, clamp curvature, thickness, modulus).
    branch : {"curvature", "gravity"}
        Loading path when ``initial`` is not given, as in the paper's FE
        protocol: curvature first, then gravity ramped up (curvature-dominated
        branch); or gravity first on a flat clamp, then the clamp curvature
        ramped up (gravity-dominated branch).  If the requested branch does
        not exist at this length the solver ends on the other one.
    impose_flat : bool
        Impose c == 0: the model reduces to the heavy elastica (eq. phODE2).
    n_elements : int
        Number of cubic Hermite elements on [0, L].
    initial : RibbonResult or ndarray, optional
        Previous solution (same ``n_elements``), e.g. at a nearby length.

    Returns
    -------
    RibbonResult

    Examples
    --------
    >>> from skfem_sheet.params import Sheet
    >>> r = ribbon(Sheet(length=1.0, curvature=2.5))
    >>> r.converged, r.stable, r.deflection < 0.1
    (True, True, True)
    >>> flat = ribbon(Sheet(length=1.0), impose_flat=True)
    >>> round(flat.deflection, 3)        # heavy elastica: 0.768
    0.768
    """
    sheet = as_sheet(sheet)
    n = _validate_common(branch, n_elements)
    mesh = make_mesh(n)
    if initial is not None:
        x0 = initial.state if isinstance(initial, RibbonResult) else np.asarray(initial, float)
        if x0.shape != (4 * (n + 1),):
            raise ParameterError(f"initial must have {4 * (n + 1)} dofs (n_elements={n}), "
                             f"got shape {x0.shape}")
        P = RibbonProblem(sheet, mesh, impose_flat)
        return P.result(_sweep(P, x0, _params(sheet), "g", (1.0,))[0])
    if branch == "gravity":
        return _gravity_first(sheet, mesh, impose_flat)
    # curvature first: the clamped sheet, then gravity ramped up (one sweep in g)
    P = RibbonProblem(sheet, mesh, impose_flat)
    out = _sweep(P, _clamped_state(n + 1, sheet.curvature, impose_flat), _params(sheet), "g",
                 (0.0, 0.25, 0.5, 0.75, 1.0))
    return P.result(out[-1])


def ribbon_energy_terms(sheet, result: RibbonResult) -> dict:
    """The reduced energy of a ribbon solution, term by term.

    Parameters
    ----------
    sheet : Sheet
        The sheet ``result`` was computed for (same length).
    result : RibbonResult

    Returns
    -------
    dict
        ``stretching`` (Y/2 int E_ss^2), ``bending_ss``, ``bending_tt``,
        ``poisson`` (D nu int B_ss B_tt), ``twisting`` (D (1 - nu) int
        B_st^2) and ``gravity``, each integrated over the sheet, and their
        sum ``total`` (the energy Newton minimised); units rho g a^4.

    Examples
    --------
    >>> from skfem_sheet.params import Sheet
    >>> s = Sheet(length=0.5)
    >>> e = ribbon_energy_terms(s, ribbon(s))
    >>> e["poisson"] < 0 < e["bending_tt"]     # anticlastic curvature lowers the energy
    True
    >>> ribbon_energy_terms(s, ribbon(s, impose_flat=True))["poisson"]
    0.0
    """
    sheet = as_sheet(sheet)
    if not isinstance(result, RibbonResult) or result.length != sheet.length:
        raise ParameterError("result must be a RibbonResult computed for this sheet's length")
    mesh = make_mesh(result.state.size // 4 - 1)
    Y, D, nu = _moduli(sheet)
    ops = make_operators(mesh, sheet.extent, sheet.tip_width, weight_per_area(sheet), Y, D, nu,
                         profile=_planform_profile(sheet))
    q = np.einsum("eqjk,ek->eqj", ops.B, result.state[ops.dofs])
    dens = _energy_term_densities(q, ops.p, ops.grav, Y, D, nu)
    out = {k: float(np.sum(ops.weight * v)) for k, v in dens.items()}
    out["total"] = float(sum(out.values()))
    return out


def detect_jumps(deflection, converged=None, abs_tol: float = 0.1):
    """Flag abrupt changes of a branch traced on a (roughly regular) grid of lengths.

    Point i is a jump if d_i departs by more than ``abs_tol`` (units of a) from
    the linear extrapolation d_{i-1} + (d_{i-1} - d_{i-2}) of the two previous
    points (from d_{i-1} alone at the start and right after a jump).  On the
    paper's grids a smooth branch stays well below 0.1 a, while the branch
    switch of the rectangle at a/R = 2.5 departs by about 0.25 a.

    Parameters
    ----------
    deflection : array_like
        Deflections in continuation order.
    converged : array_like of bool, optional
        Non-converged points are never flagged and are skipped as references.
    abs_tol : float
        Threshold on the extrapolation error.

    Examples
    --------
    >>> detect_jumps([0.0, 0.01, 0.02, 0.5, 0.52, 0.54]).tolist()
    [False, False, False, True, False, False]
    """
    d = np.asarray(deflection, dtype=float)
    ok = np.ones(d.size, bool) if converged is None else np.asarray(converged, bool)
    jumped = np.zeros(d.size, dtype=bool)
    ref = []                      # indices of the last good points on the branch
    for i in range(d.size):
        if not ok[i]:
            continue
        if ref:
            pred = d[ref[-1]]
            if len(ref) >= 2:
                pred += d[ref[-1]] - d[ref[-2]]
            jumped[i] = abs(d[i] - pred) > abs_tol
        ref = [i] if jumped[i] else (ref + [i])[-2:]
    return jumped


def _order_lengths(lengths, direction):
    if direction not in _DIRECTIONS:
        raise ParameterError(f"direction must be one of {_DIRECTIONS}, got {direction!r}")
    try:
        L = np.asarray(lengths, dtype=float).ravel()
    except (TypeError, ValueError):
        raise ParameterError(f"lengths must be numbers, got {lengths!r}") from None
    if L.size == 0:
        raise ParameterError("lengths must contain at least one value")
    for v in L:
        check_range("lengths", v, 0, 100, lo_open=True)
    L = np.unique(L)
    return L if direction == "increasing" else L[::-1]


def _march(P, prev, lengths):
    """Natural continuation through ``lengths`` from the RibbonResult ``prev``
    (a sweep in L); returns the corrector results."""
    return _sweep(P, prev.state, _params(P.template.replace(length=prev.length)), "L", lengths)


def _locate_jump(P, prev, L_new, jump_tol, depth=2, substeps=8):
    """Refine the step prev.length -> L_new; return (final result, jump length or nan).

    The step is re-done in ``substeps`` sub-steps, recursively (``depth``
    levels) inside the sub-interval with the largest change of deflection.  A
    genuine discontinuity keeps a change larger than ``jump_tol`` (and at least
    half of the coarser change) on the finest interval, width step/substeps^depth;
    a steep but smooth branch does not.  The final result is the corrector's
    at ``L_new``, reached through the first level's sub-steps.
    """
    a, b = prev.length, float(L_new)
    start, final, big = prev, None, None
    for _level in range(depth):
        Ls = np.linspace(a, b, substeps + 1)[1:]
        steps = _march(P, start, Ls)
        run = [P.result(r) for r in steps]
        if final is None:
            final = steps[-1]
        d = np.array([start.deflection] + [r.deflection for r in run])
        ok = np.array([True] + [r.converged for r in run])
        if not ok.all():
            return final, float("nan")
        inc = np.abs(np.diff(d))
        k = int(np.argmax(inc))
        if inc[k] < jump_tol or (big is not None and inc[k] < 0.5 * big):
            return final, float("nan")
        big = inc[k]
        start = start if k == 0 else run[k - 1]
        a, b = start.length, run[k].length
    return final, 0.5 * (a + b)


def ribbon_continuation(sheet_template, lengths, direction: str = "increasing",
                        impose_flat: bool = False, n_elements: int = DEFAULT_ELEMENTS,
                        start=None, refine_tol: float = 0.02,
                        jump_tol: float = 0.03) -> ContinuationResult:
    """Trace a branch of the ribbon model by natural continuation in L.

    The first length is solved from scratch -- on the curvature-dominated
    branch when ``direction="increasing"`` (short sheets first), on the
    gravity-dominated one when ``"decreasing"`` (long sheets first) -- and
    each next length starts from the previous state on the fixed S = s/L grid.
    Where the followed branch ends (fold), the energy-decreasing Newton
    iteration lands on the other branch: the jump.  A step whose deflection
    departs from the linear extrapolation of the two previous points by more
    than ``refine_tol`` is re-done in sub-steps (see :func:`_locate_jump`), which
    both keeps the continuation on its branch and tells a genuine jump
    (flagged ``jumped``, located to 1/64 of the step in ``jump_at``) from a
    steep smooth change.  A point whose Newton iteration fails is reported
    ``converged=False`` and the continuation proceeds from the last converged
    state.

    Parameters
    ----------
    sheet_template : Sheet
        Parameters other than the length.
    lengths : array_like
        Lengths L/a (sorted and de-duplicated according to ``direction``).
    direction : {"increasing", "decreasing"}
    impose_flat : bool
        Impose c == 0 (heavy elastica).
    n_elements : int
        Cubic Hermite elements.
    start : RibbonResult, optional
        State to continue from instead of a fresh first solve.
    refine_tol, jump_tol : float
        Extrapolation error that triggers step refinement, and the smallest
        deflection change (units of a) counted as a jump.

    Returns
    -------
    ContinuationResult

    Examples
    --------
    >>> from skfem_sheet.params import Sheet
    >>> up = ribbon_continuation(Sheet(1.0, curvature=2.5), [1.0, 1.2, 1.4, 1.6])
    >>> bool(up.converged.all()), up.jump_lengths.round(2).tolist()
    (True, [1.39])
    """
    sheet_template = as_sheet(sheet_template)
    L = _order_lengths(lengths, direction)
    n = _validate_common("curvature", n_elements)
    if start is not None and (not isinstance(start, RibbonResult)
                              or start.state.shape != (4 * (n + 1),)):
        raise ParameterError(f"start must be a RibbonResult computed with n_elements={n}")
    refine_tol = check_range("refine_tol", refine_tol, 0, None, lo_open=True)
    jump_tol = check_range("jump_tol", jump_tol, 0, None, lo_open=True)
    mesh = make_mesh(n)
    results, jump_at, good = [], np.full(L.size, np.nan), []
    branch = "curvature" if direction == "increasing" else "gravity"
    i0 = 0
    while start is None and i0 < L.size:  # fresh solves until one converges
        res = ribbon(sheet_template.replace(length=float(L[i0])), branch=branch,
                     impose_flat=impose_flat, n_elements=n)
        results.append(res)
        if res.converged:
            start = res
            good.append(i0)
        i0 += 1
    P = RibbonProblem(sheet_template, mesh, impose_flat)
    prev = [start]  # the last converged RibbonResult

    def revise(k, Li, out, last):
        """The refinement of a step whose deflection leaves the extrapolation."""
        i = i0 + k
        res, before = P.result(out), prev[0]
        pred = before.deflection
        if len(good) >= 2 and not np.isfinite(jump_at[good[-1]]):
            r1, r2 = results[good[-1]], results[good[-2]]
            pred += (r1.deflection - r2.deflection) * (Li - r1.length) / (r1.length - r2.length)
        if not res.converged or abs(res.deflection - pred) > refine_tol:
            out, jump_at[i] = _locate_jump(P, before, Li, jump_tol)
            res = P.result(out)
        results.append(res)
        if res.converged:
            prev[0] = res
            good.append(i)
        return out

    if i0 < L.size:
        # natural continuation on the fixed S grid: a sweep in L from the start
        _sweep(P, start.state, _params(sheet_template.replace(length=start.length)), "L",
               L[i0:], revise=revise)
    d = np.array([r.deflection for r in results])
    conv = np.array([r.converged for r in results])
    stable = np.array([r.stable for r in results])
    return ContinuationResult(L, d, conv, stable, np.isfinite(jump_at), direction,
                              tuple(results), jump_at)
