"""What a solve returns: :class:`Result` (and :class:`StartRecord`, how the
solve reached full load), and :class:`SolveError`.

:meth:`Result.to_record` is **the** definition of a result row: a sweep's
table (:mod:`skfem_sheet.studies.sweep`) holds its columns and
:meth:`Result.summary` (the ``--json`` file) is made from it.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from .io import to_jsonable, write_result
from .params import Sheet
from .version import __version__

__all__ = ["Result", "SolveError", "StartRecord"]


class SolveError(RuntimeError):
    """A solve that did not reach full load; ``.result`` holds how far it got."""

    def __init__(self, message, result=None):
        super().__init__(message)
        self.result = result


@dataclass(frozen=True)
class StartRecord:
    """How a solve reached full load on its mesh (the start strategy's record).

    Attributes
    ----------
    name : str
        ``"path"`` (the load path on the mesh ``hmax``) or ``"coarse"`` (the
        load path on a coarse mesh, finished on the mesh ``hmax``).
    coarse_hmax : float
        Mesh size of the coarse path (``nan`` for ``"path"``): the coarse mesh
        whose end state and folds are carried to the mesh ``hmax``.
    coarse_factorizations, coarse_newton_iterations : int
        Work on the coarse meshes (0 without one; ``levels`` included); the
        Result's ``factorizations`` and ``newton_iterations`` count the mesh
        ``hmax``.
    fallback : str
        Why the coarse path's outcome was not used and the load path ran on
        the mesh ``hmax`` instead ("" if it was used, or not asked for).
    folds : tuple
        One entry per fold of the coarse path, carried to the mesh ``hmax``
        and located there: ``{"phase", "coarse_load", "load", "snapped"}``
        (``load`` the fold load on the mesh ``hmax``; ``snapped`` whether it
        lies inside its phase, so that the sheet snaps there too).
    levels : tuple
        The coarser meshes by which the coarse path was itself reached
        (:class:`~skfem_sheet.starts.CoarseStart`: at hmax 0.03 the path runs
        on 0.2 and is carried to 0.1), nearest first: ``{"hmax",
        "factorizations", "newton_iterations", "fallback"}`` each (``fallback``
        non-empty: the path ran on the level above instead).
    """

    name: str = "path"
    coarse_hmax: float = float("nan")
    coarse_factorizations: int = 0
    coarse_newton_iterations: int = 0
    fallback: str = ""
    folds: tuple = ()
    levels: tuple = ()

    def to_json(self) -> dict:
        return {"name": self.name, "coarse_hmax": self.coarse_hmax,
                "coarse_factorizations": self.coarse_factorizations,
                "coarse_newton_iterations": self.coarse_newton_iterations,
                "fallback": self.fallback, "folds": [dict(f) for f in self.folds],
                "levels": [dict(level) for level in self.levels]}


def _count(pair, i):
    """Entry ``i`` of a ``negative_eigenvalues`` pair (None where unknown)."""
    return pair[i] if isinstance(pair, tuple) else (pair if i == 0 else None)


@dataclass(frozen=True)
class Result:
    """Outcome of :func:`~skfem_sheet.solve.solve`.

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
        Work on the mesh ``hmax`` (Newton linearisations, factorisations,
        accepted and rejected load steps).
    back_substitutions : int
        Right-hand sides solved with a factorisation (as the linear solver counts them).
    wall_time_s, assembly_s, linear_solve_s : float
    energy : float
        Total potential energy at the last converged load.
    volume_change : float
        Relative change of the volume, ``int J dV / V - 1``.
    solver : str
        Linear-solver back-end used.
    layers : int
    steps : tuple
        ``(phase, lam, newton iterations)`` of each accepted step.
    snaps : tuple of Snap
        One :class:`~skfem_sheet.continuation.Snap` per located fold of the
        load the sheet snapped from: its phase, the fold load, the tip
        deflection at the fold and the one it landed on (empty if the branch
        held).  A snap is a located turning point of the load, nothing else:
        a steep branch is followed and records none.
    symmetric : bool
        Solved as the mirror-symmetric half (see :func:`~skfem_sheet.solve.solve`).
    branch : str
        ``"curvature-dominated"`` or ``"gravity-dominated"``: what the end
        state is, read from the state itself (:mod:`skfem_sheet.analyses.mode`),
        one name per state whichever path reached it (a result short of full
        load is named by its path's branch, switched at each snap).
    stable : bool or None
        Whether the constrained Hessian is positive definite, from the
        inertia of the tangent (``None`` if the linear solver cannot tell); a
        symmetric solve counts the antisymmetric problem's spectrum too
        (:func:`~skfem_sheet.analyses.stability.antisymmetric_stability`).  A
        converged result is never known to be unstable (the solve fails).
    negative_eigenvalues : tuple or None
        ``(symmetric, antisymmetric)``: negative eigenvalues of the
        constrained Hessian for mirror-symmetric and mirror-antisymmetric
        perturbations (a symmetric solve); for a whole sheet
        (``symmetric=False``) ``(k, None)``, ``k`` the count for every
        perturbation.  None where unknown.
    refine : int
        Nested refinements of the mesh made at ``hmax``.
    mode : Mode or None
        What ``branch`` was read from (:class:`~skfem_sheet.analyses.mode.Mode`:
        the S-curve's slope and bend at the state, in words); None if the
        solve did not converge.
    polish_iterations : int
        Simplified-Newton corrections of the final polish
        (``NewtonOptions.final_utol``; their back-substitutions are counted in
        ``back_substitutions``).
    target_gravity : float
        The full gravity load asked of :func:`~skfem_sheet.solve.solve`
        (``gravity``; a fraction of the sheet's own weight); ``gravity`` is
        the load reached.
    start_record : StartRecord
        How full load was reached (the start strategy, the coarse path's work,
        a fallback, the folds carried from the coarse mesh).
    sensitivities : Sensitivities or None
        Derivatives of the deflection, the energy and the tip angle with
        respect to the parameters asked of ``solve(..., sensitivities=...)``
        (:class:`~skfem_sheet.analyses.sensitivity.Sensitivities`;
        ``sensitivities["modulus"]`` is dd/dE); None if none were asked or
        the solve did not converge.
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
    polish_iterations: int = 0
    mode: object = field(default=None, compare=False)
    target_gravity: float = 1.0
    start_record: StartRecord = field(default_factory=StartRecord)
    sensitivities: object = field(default=None, compare=False)
    problem: object = field(default=None, repr=False, compare=False)
    w: np.ndarray = field(default=None, repr=False, compare=False)

    # -- derived fields ------------------------------------------------------
    @property
    def start(self) -> str:
        """The start strategy's name (``start_record.name``)."""
        return self.start_record.name

    @property
    def coarse_hmax(self) -> float:
        return self.start_record.coarse_hmax

    @property
    def coarse_factorizations(self) -> int:
        """Factorisations on the coarse mesh (``start_record``)."""
        return self.start_record.coarse_factorizations

    @property
    def coarse_newton_iterations(self) -> int:
        return self.start_record.coarse_newton_iterations

    @property
    def coarse_fallback(self) -> str:
        """Why the load path ran on the mesh ``hmax`` instead of the coarse
        start ("" if it did not)."""
        return self.start_record.fallback

    @property
    def snapped(self) -> bool:
        """Whether the sheet snapped from a located fold on the way."""
        return len(self.snaps) > 0

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
        ("negative_eigenvalues", "int", lambda r: _count(r.negative_eigenvalues, 0)),
        ("antisymmetric_negative_eigenvalues", "int",
         lambda r: _count(r.negative_eigenvalues, 1)),
        ("snapped", "bool?", lambda r: r.snapped),
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
        ("coarse_factorizations", "int", lambda r: r.coarse_factorizations),
        ("polish_iterations", "int", lambda r: r.polish_iterations),
        ("gravity", "float", lambda r: r.target_gravity),
        ("snaps", "str", lambda r: json.dumps(to_jsonable([s.to_json() for s in r.snaps]))),
        ("start_record", "str", lambda r: json.dumps(to_jsonable(r.start_record.to_json()))),
        ("deflection_sensitivities", "str", lambda r: "" if r.sensitivities is None
         else json.dumps(to_jsonable(r.sensitivities.of("deflection")))),
    )

    def to_record(self) -> dict:
        """The result as one flat row: parameters and outputs, plain Python values.

        The one definition of a result row (:data:`RECORD_FIELDS`): a sweep's
        table (:mod:`skfem_sheet.studies.sweep`) holds these columns, and
        :meth:`summary` is made from it.  ``snapped`` is whether the path
        snapped from a located fold; ``snaps`` and ``start_record`` are JSON
        text (one column each); ``kappa_reached``/``gravity_reached`` the load
        reached; ``linear_solver`` the back-end used; ``layers_used`` the
        layers of the mesh solved.

        Examples
        --------
        >>> from skfem_sheet import solve
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
        back-end used, ``snaps`` a list of snap records and ``start_record``
        the start strategy's record (nested); then the ``steps`` and the
        ``version``; ``mode`` (what ``branch`` was read from) and ``si`` (the
        answer in SI units for a sheet made from SI quantities, :meth:`in_si`:
        ``deflection_m``, ``energy_J``, the sheet's quantities; None
        otherwise; the SI scales also as ``params["si"]``).
        """
        rec = self.to_record()
        params = {k: rec.pop(k) for k in ("length", "tip_width", "curvature", "thickness",
                                          "modulus", "gravity", "hmax")}
        params.update(layers=rec.pop("layers_used"), refine=rec.pop("refine"))
        if self.sheet.planform is not None:
            params["planform"] = self.sheet.planform.to_dict()
        if self.sheet.si is not None:
            params["si"] = self.sheet.si.to_dict()
        out = {k: rec.pop(k) for k in (
            "deflection", "converged", "message", "path", "dofs", "newton_iterations",
            "factorizations", "back_substitutions", "load_steps", "rejected_steps",
            "wall_time_s", "linear_solve_s", "assembly_s", "energy", "volume_change",
            "kappa_reached", "gravity_reached")}
        out["solver"] = rec.pop("linear_solver")
        rec.pop("snaps")
        rec.pop("start_record")
        rec.pop("deflection_sensitivities")
        out.update(rec)  # symmetric, branch, stable, ... and any field added to the record
        out["params"] = params
        out.update(snaps=[s.to_json() for s in self.snaps],
                   start_record=self.start_record.to_json(),
                   steps=[list(x) for x in self.steps], version=__version__)
        out["mode"] = None if self.mode is None else self.mode.to_json()
        out["si"] = self.in_si()
        if self.sensitivities is not None:
            # d's derivatives by parameter name, and every output's with the cost
            out["sensitivities"] = self.sensitivities.of("deflection")
            out["sensitivity_report"] = self.sensitivities.to_json()
        return out

    def write(self, filename):
        """Write the deformed sheet (``.vtu``: displacement, pressure, psi/mu; in
        metres and pascals for a sheet made from SI quantities) or the summary
        (``.json``)."""
        write_result(self, filename)

    # -- SI and words ------------------------------------------------------------------
    def in_si(self) -> dict | None:
        """The answer in SI units, for a sheet made from SI quantities (None
        otherwise): the sheet's quantities (:meth:`~skfem_sheet.params.Sheet.in_si`,
        ``_m``, ``_Pa`` ...) and ``deflection_m`` (d, positive downward),
        ``energy_J`` (the total potential energy of the whole sheet).

        Examples
        --------
        >>> from skfem_sheet import solve
        >>> r = solve(Sheet.from_si(0.04, 0.02, 0.04, 1.2e-3, 0.016, 6e5, 1150), hmax=0.2)
        >>> bool(abs(r.in_si()["deflection_m"] - 0.04 * r.deflection) < 1e-15)
        True
        """
        si = self.sheet.si
        if si is None:
            return None
        q = self.sheet.in_si()
        out = {f"{k}_m": q[k] for k in ("base_width", "length", "tip_width", "thickness",
                                         "radius")}
        out.update(youngs_modulus_Pa=q["youngs_modulus"], density_kg_m3=q["density"],
                   gravity_m_s2=q["gravity"], deflection_m=si.metres(self.deflection),
                   energy_J=self.energy * si.energy)
        return out

    def lines(self) -> list:
        """The answer in words, a line each (``print(result)``)."""
        si = self.sheet.si
        mm = "" if si is None else f" (d = {1e3 * si.metres(self.deflection):.4g} mm)"
        status = "converged" if self.converged else f"NOT converged: {self.message}"
        out = [f"sheet: {self.sheet.describe()}" + ("" if self.target_gravity == 1.0 else
                                                    f", gravity {self.target_gravity:g}")
               + f"; {self.path}, hmax {self.hmax:g}"]
        if si is not None:
            out.append(f"  SI: {self.sheet.describe_si()}")
        out.append(f"tip deflection d/a = {self.deflection:.6f}{mm}  ({status})")
        if self.converged:
            stable = {True: "stable", False: "unstable", None: "stability unknown"}[self.stable]
            why = f" ({self.mode.reason})" if self.mode is not None else ""
            out.append(f"  {self.branch}{why}, {stable}")
        for snap in self.snaps:
            out.append(f"  snapped in the {snap.phase} phase at the fold at {snap.load:.6g} "
                       f"of its range: d/a {snap.fold_deflection:.6f} -> "
                       f"{snap.landing_deflection:.6f}")
        out.append(f"  {self.dofs} dofs, {self.newton_iterations} Newton iterations in "
                   f"{self.load_steps} load steps, {self.wall_time_s:.1f} s")
        return out

    def __str__(self) -> str:
        return "\n".join(self.lines())

    def __repr__(self) -> str:
        state = (f"{self.branch}, {'stable' if self.stable else 'stable?' if self.stable is None else 'unstable'}"
                 if self.converged else f"NOT converged ({self.message})")
        return (f"Result({self.sheet!r}, {self.path}, hmax={self.hmax:g}: "
                f"d/a = {self.deflection:.6g}, {state})")

    def _repr_pretty_(self, p, cycle) -> None:
        p.text(repr(self) if cycle else str(self))

    def _repr_html_(self) -> str:
        from html import escape

        return "<pre>" + escape(str(self)) + "</pre>"
