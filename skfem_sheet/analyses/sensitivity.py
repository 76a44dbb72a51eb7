"""Sensitivities of a solved sheet to its parameters: one back-substitution each.

At an equilibrium ``R(u(p), p) = 0``, so the state moves with a parameter as

    K du/dp = -R_p,                                              (1)

with ``K`` the (symmetric, saddle-point) tangent on the free dofs and ``R_p``
the residual's derivative at a fixed state; an output's derivative is
``dq/dp = q_p + q_u . du/dp`` (the adjoint formula, ``K`` being symmetric).
``du/dp`` is formed, all parameters in one solve with several right-hand
sides, so every output (``deflection``, ``energy``, ``tip_angle``) is the
central difference of the function the package already evaluates along the
linearised state.  ``R_p`` is exact for ``modulus`` and ``gravity`` (the
residual is linear in them), a Dirichlet-data derivative ``K_fc dU_c/dp`` for
``curvature``, and the difference of residuals on the mapped mesh (one
topology, :func:`scaled_problem`, :func:`mapped_problem`) for ``thickness``,
``length`` and ``tip_width``.  Equation (1) is solved with the solve's last
factorisation and iterative refinement against the tangent at the final
state, refactorised only where the refinement does not contract.  The
derivation, parameter by parameter: ``docs/guide/sensitivities.md``.

Examples
--------
>>> from skfem_sheet import Sheet, solve
>>> r = solve(Sheet(length=0.6, curvature=1.0), hmax=0.2, sensitivities=("modulus", "gravity"))
>>> s = r.sensitivities
>>> bool(s["modulus"] < 0 < s["gravity"])   # a stiffer sheet sags less, a heavier one more
True

The deflection depends on the modulus and the gravity only through their
ratio (divide the energy by the load factor), so ``g dd/dg = -E dd/dE``:

>>> bool(abs(1.0 * s["gravity"] + 735.0 * s["modulus"]) < 1e-6 * abs(s["gravity"]))
True
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np
from skfem import MeshTet

from ..discretisation import TaylorHoodSpace
from ..linalg import LinearSolverError, make_linear_solver
from ..mesh import SheetMesh
from ..params import ParameterError, Planform, Sheet
from ..problem import SheetProblem
from .midsurface import section_frame
from .observables import tip_deflection

__all__ = ["OUTPUTS", "PARAMETERS", "SI_UNITS", "RELATIVE_STEP", "Sensitivities",
           "check_parameters", "fold_sensitivities", "mapped_problem", "parameter_derivatives",
           "perturbed", "scaled_problem", "solve_refined", "state_sensitivities", "tip_angle"]

#: The parameters, in the order they are reported.
PARAMETERS = ("modulus", "thickness", "curvature", "gravity", "length", "tip_width")

#: The outputs differentiated, in the order they are reported.
OUTPUTS = ("deflection", "energy", "tip_angle")

#: Step of the central differences, relative to the parameter (absolute where it is 0).
#: The residual is linear in the modulus and the gravity (exact to round-off),
#: quadratic terms of the shape maps leave ``e^2 ~ 1e-10`` relative, and
#: round-off ``1e-16 / e ~ 1e-11``.
RELATIVE_STEP = 1e-5

#: Most refinement steps of equation (1) with the held factorisation before it
#: is refactorised at the state.
MAX_REFINEMENTS = 4
#: Relative residual of equation (1) at which the refinement stops (the held
#: factorisation at the state meets it at once, at 1e-12 to 6e-10) ...
REFINEMENT_TOL = 1e-8
#: ... or, where it stops contracting, the largest one accepted: the round-off
#: floor of the saddle-point solve of a thin sheet is about 6e-10 (the gravity
#: column at hmax 0.2, with the factorisation at the state or without).
ACCEPT_TOL = 1e-7

#: The SI quantity behind each parameter and its unit (``--si``): the
#: dimensionless parameter times the scale gives it (:meth:`Sensitivities.in_si`).
SI_UNITS = {"modulus": ("youngs_modulus", "Pa"), "thickness": ("thickness", "m"),
            "curvature": ("inverse_radius", "1/m"), "gravity": ("gravity", "m/s^2"),
            "length": ("length", "m"), "tip_width": ("tip_width", "m")}
_OUTPUT_UNITS = {"deflection": "m", "energy": "J", "tip_angle": "rad"}


def check_parameters(names, sheet: Sheet | None = None) -> tuple:
    """The parameter names of a request, checked: a comma-separated string or
    an iterable of names from :data:`PARAMETERS` (duplicates dropped, order
    kept).  With ``sheet``, also whether each is defined for it (a tip width
    needs a trapezoid with ``tip_width > 0``; a length a sheet without bites).

    Examples
    --------
    >>> check_parameters("modulus, curvature")
    ('modulus', 'curvature')
    >>> check_parameters(["stiffness"])
    Traceback (most recent call last):
    ...
    skfem_sheet.params.ParameterError: sensitivities must be names from modulus, thickness, curvature, gravity, length, tip_width, got 'stiffness'
    """
    if names is None:
        return ()
    if isinstance(names, str):
        names = [n.strip() for n in names.split(",") if n.strip()]
    try:
        names = list(names)
    except TypeError:
        raise ParameterError(f"sensitivities must be a list of names from "
                             f"{', '.join(PARAMETERS)}, got {names!r}") from None
    out = []
    for n in names:
        if n not in PARAMETERS:
            raise ParameterError(f"sensitivities must be names from {', '.join(PARAMETERS)}, "
                                 f"got {n!r}")
        if n not in out:
            out.append(n)
    if sheet is not None:
        planform = getattr(sheet, "planform", None)
        if "tip_width" in out:
            if planform is not None:
                raise ParameterError("sensitivities: tip_width is defined for a trapezoid only "
                                     "(a planform's width is a profile, not one number)")
            if not sheet.tip_width > 0:
                raise ParameterError("sensitivities: tip_width needs tip_width > 0 (a "
                                     "triangle's tip is a point that no change of b/a maps "
                                     "smoothly), got 0")
        if "length" in out and planform is not None and planform.bites:
            raise ParameterError("sensitivities: length is not defined for a planform with "
                                 "bites (stretching the mesh would turn the bites' circles "
                                 "into ellipses)")
    return tuple(out)


# -- the sheet at another parameter value --------------------------------------------------
def _thickness(problem) -> float:
    """The thickness of the problem's geometry (its nodes' z range: that of a
    scaled or mapped problem too)."""
    z = problem.nodes[:, 2]
    return float(z.max() - z.min())


def _width(b, xi):
    return 1.0 + (b - 1.0) * xi


def mapped_problem(problem: SheetProblem, *, length=None, tip_width=None,
                   thickness=None) -> SheetProblem:
    """``problem`` on its mesh mapped to another length, tip width or thickness.

    The vertices move (``x' = x L'/L``, ``y' = y p_b'(x/L) / p_b(x/L)`` with
    ``p_b(xi) = 1 + (b - 1) xi``, ``z' = z h'/h``); the tetrahedra, dof
    numbering, dof sets and the assembler are kept, so a state of ``problem``
    is a state of the mapped one; the space is built afresh on the mapped
    mesh (its bases evaluate the tip angle there).

    Examples
    --------
    >>> from skfem_sheet.solve import build_problem
    >>> p = build_problem(Sheet(length=1.0, tip_width=0.5), 0.25, half=True)
    >>> q = mapped_problem(p, length=1.2, tip_width=0.6, thickness=0.033)
    >>> X = q.nodes
    >>> [round(float(x), 12) for x in X.max(axis=0)]
    [1.2, 0.5, 0.0165]
    >>> bool(np.allclose(q.volume0, 1.2 * 0.5 * (1 + 0.6) / 2 * 0.033))
    True
    """
    sm = problem.sheet_mesh
    L = float(problem.length)
    b = float(sm.tip_width)
    h = _thickness(problem)
    L2 = L if length is None else float(length)
    b2 = b if tip_width is None else float(tip_width)
    h2 = h if thickness is None else float(thickness)
    if not (L2 > 0 and h2 > 0 and b2 >= 0):
        raise ParameterError(f"the mapped sheet must have length > 0, thickness > 0 and "
                             f"tip_width >= 0, got {L2!r}, {h2!r}, {b2!r}")
    if b2 != b and not b > 0:
        raise ParameterError("tip_width of a triangle (b = 0) cannot be mapped")
    # the vertices of the problem's geometry: the mesh's, scaled for a
    # with_length or scaled problem (exactly equal plan coordinates in every layer)
    zm = sm.mesh.p[2]
    X = sm.mesh.p.T * np.array([L / sm.length, 1.0, h / float(zm.max() - zm.min())])

    def plan_map(x, y):
        xi = x / L
        q = _width(b2, xi) / _width(b, xi) if b2 != b else 1.0
        return x * (L2 / L), y * q

    x2, y2 = plan_map(X[:, 0], X[:, 1])
    P = np.vstack([x2, y2, X[:, 2] * (h2 / h)])
    edge = getattr(sm, "free_edge", None)
    if edge is not None:
        edge = np.asarray(edge, dtype=float)
        if sm.length != L:                 # a stretched problem: the mesh's own edge at L
            edge = edge * np.array([L / sm.length, 1.0])
        edge = np.column_stack(plan_map(edge[:, 0], edge[:, 1]))
    mesh = SheetMesh(mesh=MeshTet(P, sm.mesh.t), length=L2, tip_width=b2, thickness=h2,
                     hmax=sm.hmax, layers=sm.layers, half=sm.half, refine=sm.refine,
                     planform=sm.planform, free_edge=edge)
    space = TaylorHoodSpace.build(mesh, problem.quadrature_order)
    return SheetProblem(_sheet_at(problem.sheet, L2, b2, h2), mesh, problem.quadrature_order,
                        space=space, assembler=problem.assembler)


def scaled_problem(problem: SheetProblem, *, length=None, thickness=None) -> SheetProblem:
    """``problem`` on its mesh scaled in x to ``length`` and in z to ``thickness``.

    The maps are diagonal and affine (``x L'/L``, ``z h'/h``), so, as for
    :meth:`~skfem_sheet.discretisation.TaylorHoodSpace.stretched`, only the
    gradients, volume weights, node coordinates and integrals change and no
    basis is built: :func:`mapped_problem` for these two maps, at a fraction
    of the cost.

    Examples
    --------
    >>> from skfem_sheet.solve import build_problem
    >>> p = build_problem(Sheet(length=1.0, tip_width=0.5), 0.25, half=True)
    >>> a, b = scaled_problem(p, length=1.1, thickness=0.032), mapped_problem(
    ...     p, length=1.1, thickness=0.032)
    >>> bool(np.allclose(a.space.dphi, b.space.dphi) and np.allclose(a.space.dx, b.space.dx)
    ...      and np.allclose(a.nodes, b.nodes) and np.allclose(a.gravity_load, b.gravity_load))
    True
    """
    space = problem.space
    L, h = float(problem.length), _thickness(problem)
    sx = 1.0 if length is None else float(length) / L
    h2 = h if thickness is None else float(thickness)
    sz = h2 / h
    if not (sx > 0 and sz > 0):
        raise ParameterError(f"the scaled sheet must have length > 0 and thickness > 0, got "
                             f"{L * sx!r}, {h2!r}")
    dphi = space.dphi.copy()
    dphi[..., 0] /= sx
    dphi[..., 2] /= sz
    dx = space.dx * (sx * sz)
    scaled = replace(space, length=L * sx, dphi=dphi, dx=dx,
                     nodes=space.nodes * np.array([sx, 1.0, sz]), load_z=space.load_z * (sx * sz),
                     volume=space.volume * sx * sz)
    sheet = problem.sheet.replace(length=L * sx, thickness=h2)
    return SheetProblem(sheet, space.mesh, problem.quadrature_order, space=scaled,
                        assembler=problem.assembler)


def _sheet_at(sheet, length, tip_width, thickness):
    """The Sheet of a mapped problem (a flaring trapezoid's planform beyond b = 1)."""
    keep = dict(curvature=sheet.curvature, modulus=sheet.modulus)
    if sheet.planform is not None:
        return Sheet.from_planform(sheet.planform, length=length, thickness=thickness, **keep)
    if tip_width <= 1.0:
        return Sheet(length=length, tip_width=tip_width, thickness=thickness, **keep)
    return Sheet.from_planform(Planform.trapezoid(tip_width), length=length,
                               thickness=thickness, **keep)


@dataclass(frozen=True)
class _Point:
    """The sheet at one parameter value: its problem, gravity and clamp values."""

    problem: SheetProblem
    gravity: float
    kappa: float


def perturbed(problem: SheetProblem, gravity: float, name: str, value: float):
    """``(problem, gravity, curvature)`` with the parameter ``name`` at ``value``.

    The modulus gives the same mesh and space with another Sheet; the gravity
    and the curvature the same problem (they enter through the load factor
    and the clamped values); the length and the thickness the scaled mesh
    (:func:`scaled_problem`), the tip width the mapped one (:func:`mapped_problem`).
    """
    sheet = problem.sheet
    kappa = sheet.curvature
    if name == "modulus":
        p = SheetProblem(sheet.replace(modulus=value), problem.sheet_mesh,
                         problem.quadrature_order, space=problem.space,
                         assembler=problem.assembler)
        return p, gravity, kappa
    if name == "gravity":
        return problem, value, kappa
    if name == "curvature":
        return problem, gravity, value
    if name in ("length", "thickness"):
        return scaled_problem(problem, **{name: value}), gravity, kappa
    return mapped_problem(problem, **{name: value}), gravity, kappa


def _value(problem, gravity, name):
    if name == "gravity":
        return float(gravity)
    if name == "length":
        return float(problem.length)
    if name == "tip_width":
        return float(problem.sheet_mesh.tip_width)
    if name == "thickness":
        return _thickness(problem)
    return float(getattr(problem.sheet, name))


def _step(value):
    return RELATIVE_STEP * abs(value) if value != 0 else RELATIVE_STEP


def parameter_derivatives(problem: SheetProblem, w, gravity: float, parameters, *,
                          stats=None):
    """``R_p`` of each parameter at the state ``w`` (free rows), and the
    derivative of the clamped values.

    Returns
    -------
    R_p : ndarray (n_free, k)
        ``dR/dp`` of the free residual, the clamped values' contribution
        ``K_fc dU_c/dp`` included.
    dU_c : ndarray (n_clamp, k)
        ``d clamp_values / dp`` (nonzero for the curvature and the thickness).
    points : list of (minus, plus, step)
        The sheet at ``p -+ e`` (:class:`_Point`), for the outputs' differences.
    """
    w = np.asarray(w, dtype=float)
    free = problem.free
    k = len(parameters)
    R_p = np.zeros((len(free), k))
    dU_c = np.zeros((len(problem.clamp_dofs), k))
    points = []
    K_fc = None
    for j, name in enumerate(parameters):
        p0 = _value(problem, gravity, name)
        e = _step(p0)
        ends = [_Point(*perturbed(problem, gravity, name, p0 + s * e)) for s in (-1.0, 1.0)]
        points.append((ends[0], ends[1], e))
        if not (ends[0].problem is ends[1].problem and ends[0].gravity == ends[1].gravity):
            r = []
            for pt in ends:
                rr, jmin = pt.problem.residual(w, pt.gravity)
                if stats is not None:
                    stats["residual_evaluations"] += 1
                if not jmin > 0:
                    raise ParameterError(f"sensitivities: the state inverts an element at "
                                         f"{name} = {p0:g} -+ {e:g}")
                r.append(rr[free])
            R_p[:, j] = (r[1] - r[0]) / (2 * e)
        if name == "curvature":
            dU_c[:, j] = problem.clamp_rate(p0)
        elif name == "thickness":
            c = [pt.problem.clamp_values(pt.kappa) for pt in ends]
            dU_c[:, j] = (c[1] - c[0]) / (2 * e)
        if np.any(dU_c[:, j]):
            if K_fc is None:
                K_fc = problem.clamp_coupling(w)
            R_p[:, j] += K_fc @ dU_c[:, j]
    return R_p, dU_c, points


# -- the outputs ---------------------------------------------------------------------------
def tip_angle(problem: SheetProblem, w) -> float:
    """phi(L): the angle of the deformed centre line at the free edge (radians,
    positive up), ``atan2(r'_z, r'_x)`` of the mean tangent ``r'(L)`` over the
    width (:func:`~skfem_sheet.analyses.midsurface.section_frame` at ``s = L``).

    Examples
    --------
    >>> from skfem_sheet import solve
    >>> r = solve(Sheet(length=0.6), hmax=0.2)
    >>> bool(-0.6 < tip_angle(r.problem, r.w) < 0)    # the flat sheet's tip points down
    True
    """
    return float(section_frame(problem, w, [problem.length]).angle[0])


_OUTPUT_FUNCTIONS = {
    "deflection": lambda problem, w, g: tip_deflection(problem, w),
    "energy": lambda problem, w, g: problem.energy(w, g),
    "tip_angle": lambda problem, w, g: tip_angle(problem, w),
}


def _check_outputs(outputs):
    outputs = tuple(outputs)
    bad = [o for o in outputs if o not in OUTPUTS]
    if bad or not outputs:
        raise ParameterError(f"outputs must be names from {', '.join(OUTPUTS)}, got {outputs!r}")
    return outputs


# -- the linear solves ---------------------------------------------------------------------
def solve_refined(problem, w, B, linear, stats=None):
    """``K(w)^-1 B`` with the factorisation ``linear`` holds, refined against
    the tangent assembled at ``w`` (refactorised there if that does not contract):
    the answer of the tangent at the state, whichever nearby state the held
    factorisation was made at.  ``stats`` (a dict) counts the work."""
    if stats is None:
        stats = dict(residual_evaluations=0, back_substitutions=0, factorizations=0,
                     tangent_assemblies=0, refinement_steps=0, residual=0.0)
    K = problem.tangent(w)
    stats["tangent_assemblies"] += 1
    norm_b = np.linalg.norm(B, axis=0)
    norm_b[norm_b == 0] = 1.0
    X = None
    if linear is not None:
        try:
            X = linear.solve(B)
        except (AttributeError, TypeError, ValueError, RuntimeError, LinearSolverError):
            X = None        # no factorisation held: factorise below
        else:
            stats["back_substitutions"] += B.shape[1]
            previous = np.inf
            for _ in range(MAX_REFINEMENTS + 1):
                rel = float(np.max(np.linalg.norm(B - K @ X, axis=0) / norm_b))
                stats["residual"] = rel
                if rel <= REFINEMENT_TOL:
                    return X
                if not (np.isfinite(rel) and rel <= 0.5 * previous):
                    if rel <= ACCEPT_TOL:      # stagnates at round-off
                        return X
                    X = None
                    break
                previous = rel
                X = X + linear.solve(B - K @ X)
                stats["back_substitutions"] += B.shape[1]
                stats["refinement_steps"] += 1
            else:
                if not stats["residual"] <= ACCEPT_TOL:
                    X = None
    if X is None:
        # a back-end to factorise the tangent at w: the solve's own, or a fresh one
        # where ``linear`` only holds a factorisation (a continuation step's)
        solver = linear if callable(getattr(linear, "factorize", None)) else \
            make_linear_solver("auto")
        solver.factorize(K, w)
        stats["factorizations"] += 1
        X = solver.solve(B)
        stats["back_substitutions"] += B.shape[1]
        X = X + solver.solve(B - K @ X)           # one refinement step (round-off)
        stats["back_substitutions"] += B.shape[1]
        stats["residual"] = float(np.max(np.linalg.norm(B - K @ X, axis=0) / norm_b))
    return X


@dataclass(frozen=True)
class Sensitivities:
    """Derivatives of a solved sheet's outputs with respect to its parameters.

    Attributes
    ----------
    parameters : tuple of str
        From :data:`PARAMETERS` (``gravity``: the load factor, 1 at full weight).
    outputs : tuple of str
        From :data:`OUTPUTS`.
    values : tuple of tuple
        ``values[i][j] = d outputs[i] / d parameters[j]``, dimensionless
        (lengths in a, energies in rho g a^4, the modulus in rho g a).
    back_substitutions : int
        One per parameter and per refinement step.
    factorizations : int
        Only where the held factorisation did not serve (0 after a solve).
    tangent_assemblies : int
        The tangent at the state, for the refinement (1).
    refinement_steps : int
        Iterative refinement steps of equation (1).
    residual_evaluations : int
        Residuals at perturbed parameters (two per parameter that enters the
        residual at a fixed state).
    relative_residual : float
        Largest ``||K du/dp + R_p|| / ||R_p||`` of the solved equation (1).
    time_s : float
        Wall time of the whole computation.
    load_factor : float
        The load factor of the state (``gravity`` of the solve).
    si : tuple or None
        ``(base_width, density, gravity)`` in SI units (m, kg/m^3, m/s^2), if
        the sheet was given in SI units: then :meth:`to_json` also holds the
        values in SI units (:meth:`in_si`).
    """

    parameters: tuple
    outputs: tuple
    values: tuple
    back_substitutions: int = 0
    factorizations: int = 0
    tangent_assemblies: int = 0
    refinement_steps: int = 0
    residual_evaluations: int = 0
    relative_residual: float = 0.0
    time_s: float = 0.0
    load_factor: float = 1.0
    si: tuple | None = None

    def of(self, output: str = "deflection") -> dict:
        """``{parameter: d output / d parameter}``."""
        if output not in self.outputs:
            raise ParameterError(f"output must be one of {', '.join(self.outputs)}, "
                                 f"got {output!r}")
        row = self.values[self.outputs.index(output)]
        return dict(zip(self.parameters, row))

    def __getitem__(self, parameter: str) -> float:
        """``d deflection / d parameter``."""
        if parameter not in self.parameters:
            raise KeyError(parameter)
        return self.of("deflection")[parameter]

    def with_si(self, base_width: float, density: float, gravity: float = 9.81) -> Sensitivities:
        """The same sensitivities, reported also in SI units (see :meth:`in_si`)."""
        return replace(self, si=(float(base_width), float(density), float(gravity)))

    def in_si(self, base_width=None, density=None, gravity=None) -> dict:
        """The values in SI units: ``{output: {si_name: value}}`` and the units.

        The sheet's scales: lengths ``a`` (the base width), the modulus ``rho g a``,
        energies ``rho g a^4``.  The parameters become ``youngs_modulus`` (Pa),
        ``thickness``, ``length``, ``tip_width`` (m), ``inverse_radius`` 1/R
        (1/m, so that a flat clamp has a derivative too) and ``gravity`` the
        acceleration g (m/s^2; the load is the load factor times rho g, so
        ``d/dg = (load factor / g) d/d(load factor)``).  The outputs: the
        deflection in m, the energy in J, the tip angle in rad.

        Examples
        --------
        >>> s = Sensitivities(("modulus", "length"), ("deflection",), ((-1e-4, 0.5),))
        >>> si = s.in_si(0.05, 1250.0, 9.81)
        >>> round(si["values"]["deflection"]["youngs_modulus"] * 1250 * 9.81, 12)
        -0.0001
        >>> si["units"]["deflection"]["length"]
        'm/m'
        """
        if base_width is None:
            if self.si is None:
                raise ParameterError("in_si needs base_width, density and gravity (this "
                                     "sheet was not given in SI units)")
            base_width, density, gravity = self.si
        gravity = 9.81 if gravity is None else gravity
        a, rho, g = float(base_width), float(density), float(gravity)
        out_scale = {"deflection": a, "energy": rho * g * a**4, "tip_angle": 1.0}
        par_scale = {"modulus": rho * g * a, "thickness": a, "length": a, "tip_width": a,
                     "curvature": 1.0 / a,
                     "gravity": (g / self.load_factor) if self.load_factor else math.inf}
        values, units = {}, {}
        for out, row in zip(self.outputs, self.values):
            values[out], units[out] = {}, {}
            for name, v in zip(self.parameters, row):
                si_name, unit = SI_UNITS[name]
                values[out][si_name] = v * out_scale[out] / par_scale[name]
                units[out][si_name] = f"{_OUTPUT_UNITS[out]}/({unit})" if "/" in unit \
                    else f"{_OUTPUT_UNITS[out]}/{unit}"
        return {"values": values, "units": units,
                "scales": {"base_width": a, "density": rho, "gravity": g}}

    def to_json(self) -> dict:
        """JSON-ready: ``{output: {parameter: value}}`` under ``values``, the
        cost, and with :attr:`si` the SI values under ``si``."""
        out = {"parameters": list(self.parameters),
               "values": {o: self.of(o) for o in self.outputs},
               "back_substitutions": self.back_substitutions,
               "factorizations": self.factorizations,
               "tangent_assemblies": self.tangent_assemblies,
               "refinement_steps": self.refinement_steps,
               "residual_evaluations": self.residual_evaluations,
               "relative_residual": self.relative_residual, "time_s": self.time_s}
        if self.si is not None:
            out["si"] = self.in_si()
        return out


def state_sensitivities(problem: SheetProblem, w, gravity: float, parameters, *,
                        linear=None, outputs=OUTPUTS) -> Sensitivities:
    """Sensitivities of the outputs at the equilibrium ``w`` of ``problem``.

    Parameters
    ----------
    problem : SheetProblem
    w : ndarray
        An equilibrium at the load factor ``gravity`` and the clamp curvature
        ``problem.sheet.curvature`` (as :func:`~skfem_sheet.solve.solve` returns it).
    gravity : float
        The load factor of the state.
    parameters : str or iterable of str
        Names from :data:`PARAMETERS`.
    linear : linear solver, optional
        A back-end holding a factorisation of the tangent near ``w`` (the
        solve's), used with iterative refinement (see the module).  Default:
        factorise the tangent at ``w``.
    outputs : iterable of str
        Names from :data:`OUTPUTS`.

    Returns
    -------
    Sensitivities
    """
    t0 = time.perf_counter()
    parameters = check_parameters(parameters, problem.sheet)
    if not parameters:
        raise ParameterError("sensitivities needs at least one parameter name from "
                             f"{', '.join(PARAMETERS)}")
    outputs = _check_outputs(outputs)
    w = np.asarray(w, dtype=float)
    stats = dict(residual_evaluations=0, back_substitutions=0, factorizations=0,
                 tangent_assemblies=0, refinement_steps=0, residual=0.0)
    R_p, dU_c, points = parameter_derivatives(problem, w, gravity, parameters, stats=stats)
    du = -solve_refined(problem, w, R_p, linear, stats)
    values = []
    for out in outputs:
        q = _OUTPUT_FUNCTIONS[out]
        row = []
        for j, (lo, hi, e) in enumerate(points):
            dw = np.zeros_like(w)
            dw[problem.free] = du[:, j]
            dw[problem.clamp_dofs] = dU_c[:, j]
            row.append((q(hi.problem, w + e * dw, hi.gravity)
                        - q(lo.problem, w - e * dw, lo.gravity)) / (2 * e))
        values.append(tuple(float(v) for v in row))
    return Sensitivities(parameters=parameters, outputs=outputs, values=tuple(values),
                         back_substitutions=stats["back_substitutions"],
                         factorizations=stats["factorizations"],
                         tangent_assemblies=stats["tangent_assemblies"],
                         refinement_steps=stats["refinement_steps"],
                         residual_evaluations=stats["residual_evaluations"],
                         relative_residual=stats["residual"],
                         time_s=time.perf_counter() - t0, load_factor=float(gravity))


def fold_sensitivities(problem: SheetProblem, w, null_vector, gravity: float, parameters, *,
                       fold_parameter: str = "length") -> dict:
    """Derivatives of a fold's location with respect to the other parameters.

    At a fold in ``P`` (the length, for the standout and pop-up lengths) the
    tangent is singular with the null vector ``phi``; along the fold,
    ``R(u*(p), P*(p), p) = 0`` and ``phi . R_u = 0`` give

        dP*/dp = -(phi . R_p) / (phi . R_P)

    (the state's own sensitivity diverges there; the fold's does not).
    ``R_p`` and ``R_P`` are those of :func:`parameter_derivatives`.

    Parameters
    ----------
    problem : SheetProblem
        The sheet at the fold (e.g. the mapped problem of a
        :class:`~skfem_sheet.foldcurve.SheetFoldProblem` at the fold's
        parameters, with its curvature).
    w : ndarray
        The state at the fold (all dofs).
    null_vector : ndarray
        ``phi`` on the free dofs (its scale does not matter).
    gravity : float
        The load factor of the state.
    parameters : str or iterable of str
        Names from :data:`PARAMETERS`, not ``fold_parameter``.
    fold_parameter : str
        The parameter in which the branch turns (``length``, ``tip_width``
        or ``curvature``).

    Returns
    -------
    dict
        ``{parameter: dP*/dp}``.

    Raises
    ------
    ParameterError
        For ``phi . R_P = 0`` (relative to ``|phi| |R_P|``): then the branch
        does not turn in ``P`` there (a bifurcation, not a fold).
    """
    parameters = check_parameters(parameters, problem.sheet)
    fold_parameter = check_parameters([fold_parameter], problem.sheet)[0]
    if fold_parameter in parameters:
        raise ParameterError(f"parameters must not include the fold's own parameter "
                             f"{fold_parameter!r}")
    phi = np.asarray(null_vector, dtype=float)
    if phi.shape != (len(problem.free),) or not np.all(np.isfinite(phi)) or not np.any(phi):
        raise ParameterError(f"null_vector must be a nonzero vector on the {len(problem.free)} "
                             f"free dofs, got shape {phi.shape}")
    R_p, _, _ = parameter_derivatives(problem, np.asarray(w, dtype=float), gravity,
                                      (*parameters, fold_parameter))
    den = float(phi @ R_p[:, -1])
    if not abs(den) > 1e-9 * np.linalg.norm(phi) * np.linalg.norm(R_p[:, -1]):
        raise ParameterError(f"the branch does not turn in {fold_parameter} at this point "
                             f"(phi . R_{fold_parameter} = {den:.3g}): not a fold in it")
    return {name: -float(phi @ R_p[:, j]) / den for j, name in enumerate(parameters)}
