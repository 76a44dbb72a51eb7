"""The model against an experiment: fold-length sensitivities and calibration.

Two questions of a researcher with their own sheets (paper, Figs. 2, 3, 5):

- *How sensitive are the standout and pop-up lengths to the thickness, the
  modulus, ...?*  :func:`locate_folds` locates ``L1*`` and ``L0*`` and
  differentiates each by ``dL*/dp = -(phi . R_p) / (phi . R_L)``
  (:func:`fold_point_sensitivities`): no fold is located again.
- *Which modulus makes the model match the deflections I observed?*
  :func:`calibrate` fits free parameters by least squares, each solve giving
  its Jacobian row by one back-substitution, with standard errors from
  ``J^T J``; it refuses, saying why, data that cannot determine the
  parameters and a measurement whose model state lies across a snap.

Examples
--------
>>> from skfem_sheet import Sheet, solve
>>> sheet = Sheet(length=0.6, curvature=1.0)
>>> truth = [solve(sheet.replace(length=L, modulus=800.0), hmax=0.2).deflection
...          for L in (0.5, 0.7)]
>>> fit = calibrate(sheet, [(0.5, truth[0]), (0.7, truth[1])], hmax=0.2)
>>> round(fit["modulus"], 3), fit.solves <= 10
(800.0, True)
"""
from __future__ import annotations

import csv
import math
import time
from dataclasses import dataclass, field

import numpy as np

from .analyses.observables import tip_deflection
from .analyses.sensitivity import PARAMETERS, check_parameters, fold_sensitivities
from .bistability import fold_lengths
from .continuation import PATHS
from .engine import Tolerances
from .foldcurve import SheetFoldProblem
from .params import DEFAULT_HMAX, ParameterError, Sheet, check_finite, check_range
from .problem import SheetProblem
from .result import SolveError
from .solve import solve
from .version import __version__

__all__ = ["FIT_PARAMETERS", "FOLD_TOLERANCES", "Calibration", "CalibrationError",
           "FoldSensitivities", "Measurement", "calibrate", "fold_point_sensitivities",
           "locate_folds", "read_measurements"]

#: The fold's own parameter, by the name the engine's fold problems use.
_FOLD_PARAMETER = {"L": "length", "b": "tip_width", "a/R": "curvature"}

#: The corrector of :func:`locate_folds`'s final location: tighter than the
#: fold curves' (:data:`~skfem_sheet.foldcurve.TOLERANCES`, L to 1e-6), so
#: that a fold moved by a relative parameter change of 1e-3 (``dL*`` about
#: 1e-4 a) is resolved to 1e-5 of that change.
FOLD_TOLERANCES = Tolerances(rtol=1e-6, utol=1e-10, max_iterations=16, max_correction=0.3)


# ------------------------------------------------------------------------------------------
# fold lengths and their sensitivities
# ------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class FoldSensitivities:
    """A located fold and its sensitivities.

    Attributes
    ----------
    kind : str
        ``"standout"`` (the curvature-dominated branch ends: ``L1*``),
        ``"popup"`` (the gravity-dominated one: ``L0*``) or ``"fold"``.
    parameter : str
        The parameter the branch turns in (``length`` for L0*, L1*).
    value : float
        Its value at the fold (``L*``).
    sensitivities : dict
        ``{parameter: dL*/dp}`` (dimensionless: ``gravity`` is the load factor).
    fold_deflection : float
        The tip deflection at the fold.
    factorizations : int
        Work of locating the fold (the solve and the continuation included).
    fold : FoldPoint
        The located fold (state, parameters, null vector).
    problem : SheetFoldProblem
        The problem it was located on (the mesh: ``problem.mesh_parameters``).
    """

    kind: str
    parameter: str
    value: float
    sensitivities: dict
    fold_deflection: float = math.nan
    factorizations: int = 0
    fold: object = field(default=None, repr=False, compare=False)
    problem: object = field(default=None, repr=False, compare=False)

    def __getitem__(self, name):
        return self.sensitivities[name]

    def to_json(self) -> dict:
        return {"kind": self.kind, "parameter": self.parameter, "value": self.value,
                "sensitivities": dict(self.sensitivities),
                "fold_deflection": self.fold_deflection,
                "factorizations": self.factorizations}


def _fold_kind(fold) -> str:
    side = int(getattr(fold, "side", 0))
    return "standout" if side < 0 else "popup" if side > 0 else "fold"


def _sheet_at_fold(fold_problem: SheetFoldProblem, fold):
    """The SheetProblem at the fold's parameters (its curvature in the Sheet)
    and the full state there."""
    p = np.asarray(fold.p, dtype=float)
    problem = fold_problem.problem(p)
    kappa = float(p[2]) if len(p) > 2 else fold_problem.curvature
    if kappa != problem.sheet.curvature:
        problem = SheetProblem(problem.sheet.replace(curvature=kappa), problem.sheet_mesh,
                               problem.quadrature_order, space=problem.space,
                               assembler=problem.assembler)
    return problem, fold_problem.full(fold.u, p)


def fold_point_sensitivities(fold_problem: SheetFoldProblem, fold, parameters=None, *,
                             u=None, v=None) -> FoldSensitivities:
    """Sensitivities of a located fold of a :class:`~skfem_sheet.foldcurve.SheetFoldProblem`.

    Parameters
    ----------
    fold_problem : SheetFoldProblem
        The problem the fold was located on.
    fold : skfem_sheet.engine.FoldPoint or FoldCurvePoint
        From :func:`skfem_sheet.engine.locate_fold` or a continuation's
        ``branch.fold`` (state, parameters ``(L, b, a/R)``, null vector, the
        index of the parameter it turns in), or a point of a fold curve
        (:func:`skfem_sheet.engine.fold_curve`: a fold in L; its state and
        null vector are those its ``on_point`` callback receives, pass them
        as ``u`` and ``v``).
    parameters : iterable of str, optional
        Default: every parameter of :data:`~skfem_sheet.analyses.sensitivity.PARAMETERS`
        but the fold's own (``length`` for a fold in L).
    u, v : ndarray, optional
        The state and the null vector at the fold (free dofs), where ``fold``
        does not hold them.

    Returns
    -------
    FoldSensitivities
    """
    index = int(getattr(fold, "parameter", 0))
    own = _FOLD_PARAMETER[fold_problem.parameter_names[index]]
    u = fold.u if u is None else u
    v = getattr(fold, "v", None) if v is None else v
    if u is None or v is None:
        raise ParameterError("the fold's state u and null vector v are needed (a fold curve "
                             "point holds neither: pass those of its on_point callback)")
    if parameters is None:
        parameters = [p for p in PARAMETERS if p != own]
    p = np.asarray(fold.p, dtype=float)
    point = _Located(u=np.asarray(u, dtype=float), p=p)
    problem, w = _sheet_at_fold(fold_problem, point)
    sens = fold_sensitivities(problem, w, v, 1.0, parameters, fold_parameter=own)
    return FoldSensitivities(kind=_fold_kind(fold), parameter=own, value=float(p[index]),
                             sensitivities=sens, fold_deflection=tip_deflection(problem, w),
                             fold=fold, problem=fold_problem)


@dataclass(frozen=True)
class _Located:
    u: np.ndarray
    p: np.ndarray


def locate_folds(sheet: Sheet = None, *legacy, hmax: float = DEFAULT_HMAX,
                 kinds=("standout", "popup"), lengths=None, layers=None, solver: str = "auto",
                 parameters=None, progress: bool = False, **legacy_keywords) -> dict:
    """The standout and pop-up lengths of a sheet's planform at its curvature
    and material, located, with their sensitivities.

    The folds are :func:`~skfem_sheet.bistability.fold_lengths`', each
    differentiated by ``dL*/dp = -(phi . R_p) / (phi . R_L)``
    (:func:`fold_point_sensitivities`).

    Parameters
    ----------
    sheet : Sheet
        Its planform, curvature and material (its length must lie in
        ``lengths``).
    hmax : float
    kinds : iterable of {"standout", "popup"}
    lengths : (float, float), optional
        The lengths searched (:func:`~skfem_sheet.bistability.fold_range`).
    parameters : iterable of str, optional
        Default: all but the length; ``()`` for none.
    legacy, legacy_keywords
        The old call ``locate_folds(tip_width, curvature, hmax=...,
        thickness=..., modulus=...)`` still works for one release, with a
        :class:`DeprecationWarning`.

    Returns
    -------
    dict
        ``{kind: FoldSensitivities}`` for the folds found (``problem``: the
        :class:`~skfem_sheet.sheet_shape.SheetShapeProblem` of the fold's
        mesh, in L; ``fold``: the located fold on it).

    Raises
    ------
    ParameterError
        If a fold asked for is not found (not bistable at this sheet, or a
        length range that misses it), naming why.
    """
    if not isinstance(sheet, Sheet):
        sheet = _legacy_sheet(sheet, legacy, legacy_keywords)
    elif legacy or legacy_keywords:
        raise ParameterError("locate_folds(sheet, ...) takes the planform, curvature, "
                             "thickness and modulus from the Sheet, got also "
                             f"{', '.join(sorted(legacy_keywords)) or 'positional arguments'}")
    kinds = tuple(kinds)
    for k in kinds:
        if k not in ("standout", "popup"):
            raise ParameterError(f"kinds must be from standout, popup, got {k!r}")
    if sheet.curvature == 0:
        raise ParameterError("curvature must be in (0, 2 pi) for fold lengths, got 0 (a flat "
                             "clamp has one branch)")
    folds = fold_lengths(sheet, hmax=hmax, lengths=lengths, layers=layers, solver=solver,
                         progress=progress, keep_states=True)
    found = {}
    for kind in kinds:
        fold = folds.standout if kind == "standout" else folds.popup
        if fold is None:
            raise ParameterError(f"no {'standout' if kind == 'standout' else 'pop-up'} fold "
                                 f"of {sheet.describe()} in L/a {folds.length_range}: "
                                 f"{folds.fold_text(kind)}")
        fs = fold_point_sensitivities(fold.problem, fold.point, parameters)
        found[kind] = _with_work(fs, fold.factorizations)
    return found


def _legacy_sheet(tip_width, legacy, keywords) -> Sheet:
    """The Sheet of the old call ``locate_folds(tip_width, curvature, ...)``
    (with a deprecation warning)."""
    import warnings

    warnings.warn("locate_folds(tip_width, curvature, thickness=, modulus=) is deprecated: "
                  "pass the Sheet, locate_folds(Sheet(length=..., tip_width=..., "
                  "curvature=..., thickness=..., modulus=...), hmax=...)",
                  DeprecationWarning, stacklevel=3)
    names = ("tip_width", "curvature")
    given = dict(zip(names[1:], legacy))
    if tip_width is not None:
        given["tip_width"] = tip_width
    for k in ("tip_width", "curvature", "thickness", "modulus", "start_length",
              "length_range"):
        if k in keywords:
            given[k] = keywords.pop(k)
    if keywords:
        raise ParameterError(f"locate_folds got unknown arguments {', '.join(sorted(keywords))}")
    lo, hi = given.pop("length_range", (0.5, 3.0))
    start = given.pop("start_length", None)
    return Sheet(length=start if start is not None else lo, tip_width=given.get("tip_width", 1.0),
                 curvature=given.get("curvature", 2.5), thickness=given.get("thickness", 0.03),
                 modulus=given.get("modulus", 735.0))


def _with_work(fs: FoldSensitivities, nfact) -> FoldSensitivities:
    return FoldSensitivities(fs.kind, fs.parameter, fs.value, fs.sensitivities,
                             fs.fold_deflection, int(nfact), fs.fold, fs.problem)
# ------------------------------------------------------------------------------------------
# calibration
# ------------------------------------------------------------------------------------------
#: The parameters :func:`calibrate` can fit (the length and the tip width are
#: the measurements' own).
FIT_PARAMETERS = ("modulus", "thickness", "curvature", "gravity")

#: Bounds of the fitted parameters (those of :class:`~skfem_sheet.params.Sheet`
#: and of :func:`~skfem_sheet.solve.solve`'s ``gravity``).
_BOUNDS = {"modulus": (0.0, 1e9), "thickness": (0.0, 0.5), "curvature": (0.0, 2 * math.pi),
           "gravity": (0.0, 10.0)}

#: ``J^T J`` is refused as singular where the smallest singular value of the
#: Jacobian (each column scaled by its parameter) is below this fraction of
#: the largest, or a column below this fraction of the deflections
#: themselves: the sensitivities are accurate to about 1e-7 relative (the
#: linear solve's round-off floor), so a direction determined to less than
#: 1e-6 of the best one is not determined by them.
SINGULAR_RATIO = 1e-6


class CalibrationError(ParameterError):
    """A calibration refused: the data cannot determine the parameters, or a
    measurement lies across a snap, or a solve failed (the message says which)."""


@dataclass(frozen=True)
class Measurement:
    """One observed tip deflection and the sheet it was observed on.

    Attributes
    ----------
    deflection : float
        d/a, positive downward (the package's :func:`~skfem_sheet.analyses.observables.tip_deflection`).
    length : float or None
        L/a of the observed sheet (None: that of the sheet given to :func:`calibrate`).
    tip_width : float or None
        Its b/a (None: the calibration sheet's).
    curvature : float or None
        Its a/R (None: the calibration sheet's).
    uncertainty : float or None
        Standard deviation of ``deflection`` (in a); give it for all
        measurements or for none.
    path : str or None
        The load path that selects this sheet's branch (None: the
        calibration's).
    """

    deflection: float
    length: float | None = None
    tip_width: float | None = None
    curvature: float | None = None
    uncertainty: float | None = None
    path: str | None = None

    def __post_init__(self):
        set_ = object.__setattr__
        set_(self, "deflection", check_finite("deflection", self.deflection))
        for name in ("length", "tip_width", "curvature"):
            v = getattr(self, name)
            if v is not None:
                set_(self, name, check_finite(name, v))
        if self.uncertainty is not None:
            set_(self, "uncertainty", check_range("uncertainty", self.uncertainty, 0, None,
                                                  lo_open=True))
        if self.path is not None and self.path not in PATHS:
            raise ParameterError(f"path must be one of {', '.join(PATHS)}, got {self.path!r}")

    @classmethod
    def of(cls, item) -> Measurement:
        """A Measurement from itself, a dict of its fields, or a pair ``(length, deflection)``."""
        if isinstance(item, Measurement):
            return item
        if isinstance(item, dict):
            unknown = set(item) - {f for f in cls.__dataclass_fields__}
            if unknown:
                raise ParameterError(f"a measurement has the fields {', '.join(cls.__dataclass_fields__)}, "
                                     f"got {', '.join(sorted(unknown))}")
            return cls(**item)
        try:
            length, deflection = item
        except (TypeError, ValueError):
            raise ParameterError(f"a measurement must be a Measurement, a dict or a pair "
                                 f"(length, deflection), got {item!r}") from None
        return cls(deflection=deflection, length=length)


def read_measurements(path) -> tuple:
    """Measurements from a CSV file with a header: ``length`` and ``deflection``
    columns, optionally ``tip_width``, ``curvature``, ``uncertainty``, ``path``
    (empty cells: the calibration's values)."""
    try:
        with open(path, newline="") as fh:
            rows = list(csv.DictReader(fh))
    except OSError as err:
        raise ParameterError(f"measurements file {path!r} cannot be read: {err}") from None
    if not rows:
        raise ParameterError(f"measurements file {path!r} has no rows")
    fields = set(Measurement.__dataclass_fields__)
    if "deflection" not in rows[0]:
        raise ParameterError(f"measurements file {path!r} needs a 'deflection' column, got "
                             f"{', '.join(rows[0])}")
    out = []
    for i, row in enumerate(rows, start=2):
        unknown = set(row) - fields
        if unknown:
            raise ParameterError(f"measurements file {path!r}: unknown columns "
                                 f"{', '.join(sorted(unknown))} (allowed: {', '.join(fields)})")
        kw = {}
        for k, v in row.items():
            v = (v or "").strip()
            if not v:
                continue
            if k == "path":
                kw[k] = v
                continue
            try:
                kw[k] = float(v)
            except ValueError:
                raise ParameterError(f"measurements file {path!r}, line {i}: {k} must be a "
                                     f"number, got {v!r}") from None
        out.append(Measurement(**kw))
    return tuple(out)


@dataclass(frozen=True)
class Calibration:
    """Outcome of :func:`calibrate`.

    Attributes
    ----------
    parameters : tuple of str
        The fitted parameters.
    values : tuple of float
        Their fitted values.
    standard_errors : tuple of float
        ``sqrt(diag(C))``, ``C = s^2 (J^T J)^-1``; ``s^2 = 1`` with the
        measurements' uncertainties, else ``RSS / (n - k)`` (NaN for as many
        measurements as parameters).
    covariance : tuple of tuple
        ``C``.
    initial : tuple of float
        The starting values (the sheet's).
    measurements : tuple of Measurement
    model_deflections : tuple of float
        The model's d of each measurement at the fit.
    residuals : tuple of float
        Model minus observed d.
    branches : tuple of str
        The branch each measurement's solve ended on at the fit.
    sheet : Sheet
        The given sheet with the fitted values.
    gravity : float
        The load factor at the fit.
    path : str
        The calibration's load path.
    hmax : float
        Mesh size of the solves.
    solves : int
        Solves of the sheet (one per measurement and evaluation).
    evaluations : int
        Model evaluations (each gives the deflections and their Jacobian).
    converged : bool
    message : str
        The least-squares solver's.
    noise : str
        Where ``s^2`` came from: ``"uncertainties"``, ``"residuals"`` or
        ``"undetermined"``.
    wall_time_s : float
    """

    parameters: tuple
    values: tuple
    standard_errors: tuple
    covariance: tuple
    initial: tuple
    measurements: tuple
    model_deflections: tuple
    residuals: tuple
    branches: tuple
    sheet: Sheet
    gravity: float
    path: str
    hmax: float
    solves: int
    evaluations: int
    converged: bool
    message: str
    noise: str
    wall_time_s: float

    def __getitem__(self, name) -> float:
        """The fitted value of ``name``."""
        if name not in self.parameters:
            raise KeyError(name)
        return self.values[self.parameters.index(name)]

    def standard_error(self, name) -> float:
        return self.standard_errors[self.parameters.index(name)]

    def summary(self) -> dict:
        """JSON-ready: each fitted parameter by name (and ``<name>_standard_error``),
        ``deflection`` (the model's d at the fit: a number for one measurement,
        a list in the measurements' order for several), the measurements with
        their residuals, the covariance, the cost."""
        out = {}
        for name, v, se in zip(self.parameters, self.values, self.standard_errors):
            out[name] = v
            out[f"{name}_standard_error"] = se
        d = list(self.model_deflections)
        out["deflection"] = d[0] if len(d) == 1 else d
        out.update(
            free=list(self.parameters), initial=dict(zip(self.parameters, self.initial)),
            standard_errors=dict(zip(self.parameters, self.standard_errors)),
            covariance=[list(r) for r in self.covariance], noise=self.noise,
            measurements=[{"length": self.sheet.length if m.length is None else m.length,
                           "tip_width": (self.sheet.tip_width if m.tip_width is None
                                         else m.tip_width),
                           "curvature": (self.sheet.curvature if m.curvature is None
                                         else m.curvature),
                           "measured": m.deflection, "uncertainty": m.uncertainty,
                           "model": md, "residual": r, "branch": b,
                           "path": m.path or self.path}
                          for m, md, r, b in zip(self.measurements, self.model_deflections,
                                                 self.residuals, self.branches)],
            residuals=list(self.residuals), converged=self.converged, message=self.message,
            solves=self.solves, evaluations=self.evaluations, wall_time_s=self.wall_time_s,
            params={**self.sheet.to_dict(), "gravity": self.gravity, "hmax": self.hmax,
                    "path": self.path},
            version=__version__)
        return out


class _Model:
    """The measurements' deflections and Jacobian at parameter values, by solves
    (cached by value; the branch of each measurement watched)."""

    def __init__(self, sheet, measurements, free, path, hmax, gravity, solve_options):
        self.sheet, self.measurements, self.free = sheet, measurements, free
        self.path, self.hmax, self.gravity = path, hmax, gravity
        self.options = solve_options
        self.cache = {}
        self.solves = 0
        self.first_branch = [None] * len(measurements)

    def sheet_of(self, m, values):
        changes = {k: v for k, v in zip(self.free, values) if k != "gravity"}
        for name in ("length", "tip_width", "curvature"):
            v = getattr(m, name)
            if v is not None:
                changes[name] = v
        return self.sheet.replace(**changes)

    def __call__(self, values):
        key = tuple(float(v) for v in values)
        if key in self.cache:
            return self.cache[key]
        g = dict(zip(self.free, key)).get("gravity", self.gravity)
        d, J, branches = [], [], []
        for i, m in enumerate(self.measurements):
            where = (f"measurement {i + 1} (L/a = {m.length if m.length is not None else self.sheet.length:g}, "
                     f"d/a = {m.deflection:g})")
            try:
                sheet = self.sheet_of(m, key)
            except ParameterError as err:
                raise CalibrationError(f"{where}: no sheet at {self._at(key)}: {err}") from None
            self.solves += 1
            try:
                r = solve(sheet, path=m.path or self.path, hmax=self.hmax, gravity=g,
                          sensitivities=self.free, **self.options)
            except SolveError as err:
                raise CalibrationError(f"{where}: the solve at {self._at(key)} failed: "
                                       f"{err}") from None
            snapped = "" if not r.snaps else (
                f" (its path snapped at the fold at {r.snaps[0].load:.4g} of the "
                f"{r.snaps[0].phase} phase)")
            if self.first_branch[i] is None:
                self.first_branch[i] = (r.branch, len(r.snaps), key)
            elif (r.branch, len(r.snaps)) != self.first_branch[i][:2]:
                b0, n0, k0 = self.first_branch[i]
                raise CalibrationError(
                    f"{where} lies across a snap: at {self._at(k0)} its sheet is on the {b0} "
                    f"branch ({n0} snaps on its load path), at {self._at(key)} on the "
                    f"{r.branch} branch{snapped}; d jumps between them, so no derivative "
                    f"connects them.  Fit the measurements of one branch (choose its path), "
                    f"or start nearer the answer")
            d.append(r.deflection)
            J.append([r.sensitivities[name] for name in self.free])
            branches.append(r.branch)
        out = (np.array(d), np.array(J, dtype=float).reshape(len(d), len(self.free)),
               tuple(branches))
        self.cache[key] = out
        return out

    def _at(self, key):
        return ", ".join(f"{n} = {v:.6g}" for n, v in zip(self.free, key))


def _check_identifiable(J, free, where, reference):
    """Refuse a Jacobian (columns scaled by the parameters) whose columns are
    (nearly) dependent, or (nearly) zero against ``reference`` (the size of the
    weighted deflections)."""
    n, k = J.shape
    if n < k:
        raise CalibrationError(f"{k} free parameters ({', '.join(free)}) need at least {k} "
                               f"measurements, got {n}")
    norms = np.linalg.norm(J, axis=0)
    zero = [f for f, c in zip(free, norms) if not c > SINGULAR_RATIO * reference]
    if zero:
        raise CalibrationError(f"J^T J is singular {where}: the deflections do not depend on "
                               f"{', '.join(zero)} (their sensitivities are 0; e.g. the "
                               f"modulus without gravity)")
    s = np.linalg.svd(J / norms, compute_uv=False)
    if s[-1] < SINGULAR_RATIO * s[0]:
        _, _, vt = np.linalg.svd(J / norms)
        v = vt[-1] / norms              # the undetermined direction (relative changes)
        v = v / v[np.argmax(np.abs(v))]
        combo = ", ".join(f"{f} by {c:+.3g}%" for c, f in zip(v, free))
        raise CalibrationError(
            f"J^T J is singular {where} (condition number {s[0] / s[-1]:.3g} of the scaled "
            f"Jacobian): the measurements cannot determine {', '.join(free)} separately; "
            f"changing {combo} together leaves every deflection as it is"
            + (" (d depends on the modulus and the gravity only through their ratio)"
               if {"modulus", "gravity"} <= set(free) else ""))


def calibrate(sheet: Sheet, measurements, free=("modulus",), path: str = "curvature-first",
              hmax: float = DEFAULT_HMAX, *, gravity: float = 1.0, solver: str = "auto",
              max_evaluations: int = 20, xtol: float = 1e-5, layers=None,
              start="coarse", progress: bool = False) -> Calibration:
    """Fit free parameters of ``sheet`` to observed tip deflections.

    Least squares on ``(d_model_i - d_i) / sigma_i``
    (:func:`scipy.optimize.least_squares`, trust region reflective), each
    evaluation one solve per measurement with ``solve(...,
    sensitivities=free)`` as the Jacobian; standard errors from
    ``C = s^2 (J^T J)^-1`` at the fit.

    Parameters
    ----------
    sheet : Sheet
        The sheet: the starting values of the free parameters and the values
        of the others (the measurements may change its length, tip width and
        curvature).
    measurements : iterable
        :class:`Measurement`, dicts of its fields, or pairs ``(length, deflection)``.
    free : iterable of str
        From :data:`FIT_PARAMETERS` (``gravity``: the load factor, e.g. an
        uncertain density).
    path : {"curvature-first", "gravity-first"}
        The load path of each solve (a measurement may name its own).
    hmax : float
        Mesh size of the solves (default :data:`~skfem_sheet.params.DEFAULT_HMAX`).
    gravity : float
        The load factor (its starting value if free).
    solver, layers, start
        Passed to :func:`~skfem_sheet.solve.solve`.
    max_evaluations : int
        Most model evaluations.
    xtol : float
        Relative change of the parameters at which the fit stops (1e-5: far
        below the standard error of any observed deflection; smaller costs an
        evaluation more with noisy data).
    progress : bool
        A tqdm bar on stderr: the solves made, with the parameters tried.

    Returns
    -------
    Calibration

    Raises
    ------
    CalibrationError
        Where the measurements cannot determine the free parameters (a
        singular ``J^T J``, checked at the start and at the fit), where a
        measurement's state lies across a snap, or where a solve failed.
    """
    from scipy.optimize import least_squares

    t0 = time.perf_counter()
    if not isinstance(sheet, Sheet):
        raise ParameterError(f"sheet must be a skfem_sheet.Sheet, got {type(sheet).__name__}")
    if isinstance(free, str):
        free = [f.strip() for f in free.split(",") if f.strip()]
    free = tuple(free)
    bad = [f for f in free if f not in FIT_PARAMETERS]
    if bad or not free or len(set(free)) != len(free):
        raise ParameterError(f"free must be distinct names from {', '.join(FIT_PARAMETERS)} "
                             f"(the length and tip width are the measurements'), got {free!r}")
    check_parameters(free, sheet)
    if path not in PATHS:
        raise ParameterError(f"path must be one of {', '.join(PATHS)}, got {path!r}")
    hmax = check_range("hmax", hmax, 0, None, lo_open=True)
    gravity = check_range("gravity", gravity, 0, 10, hint="a fraction of the sheet's own weight")
    max_evaluations = int(check_range("max_evaluations", max_evaluations, 1, 1000))
    xtol = check_range("xtol", xtol, 0, 1, lo_open=True)
    try:
        ms = tuple(Measurement.of(m) for m in measurements)
    except TypeError:
        raise ParameterError(f"measurements must be an iterable of measurements, got "
                             f"{measurements!r}") from None
    if not ms:
        raise ParameterError("measurements must hold at least one measurement")
    given = [m.uncertainty is not None for m in ms]
    if any(given) and not all(given):
        raise ParameterError("uncertainty must be given for every measurement or for none")
    if "curvature" in free and any(m.curvature is not None for m in ms):
        raise ParameterError("curvature cannot be free when a measurement gives its own")
    sigma = np.array([m.uncertainty if m.uncertainty is not None else 1.0 for m in ms])
    measured = np.array([m.deflection for m in ms])

    x0 = np.array([gravity if f == "gravity" else getattr(sheet, f) for f in free], dtype=float)
    scale = np.where(x0 != 0, np.abs(x0), 1.0)
    lo = np.array([_BOUNDS[f][0] for f in free]) / scale
    hi = np.array([_BOUNDS[f][1] for f in free]) / scale
    model = _Model(sheet, ms, free, path, hmax, gravity,
                   dict(solver=solver, layers=layers, start=start))
    from tqdm.auto import tqdm

    bar = tqdm(desc="calibrate", unit="solve", disable=not progress, leave=None)

    def evaluated(x):
        out = model(x)
        bar.update(model.solves - bar.n)
        bar.set_postfix_str(model._at(x), refresh=False)
        return out

    def residuals(x):
        d, _, _ = evaluated(x * scale)
        return (d - measured) / sigma

    def jacobian(x):
        _, J, _ = evaluated(x * scale)
        return J * scale[None, :] / sigma[:, None]

    try:
        J0 = jacobian(x0 / scale)
        _check_identifiable(J0, free, f"at the start ({model._at(x0)})",
                            np.linalg.norm(model(x0)[0] / sigma))
        # the start on the boundary of a range (a flat clamp) is moved inside it
        xs = np.clip(x0 / scale, lo + 1e-12 * (hi - lo), hi - 1e-12 * (hi - lo))
        res = least_squares(residuals, xs, jac=jacobian, bounds=(lo, hi), method="trf",
                            x_scale=1.0, xtol=xtol, ftol=1e-12, gtol=1e-12,
                            max_nfev=max_evaluations)
        x = res.x * scale
        d, J, branches = evaluated(x)
    finally:
        bar.close()
    Jw = J / sigma[:, None]
    _check_identifiable(Jw * scale[None, :], free, f"at the fit ({model._at(x)})",
                        np.linalg.norm(d / sigma))
    n, k = Jw.shape
    r = (d - measured) / sigma
    if all(given):
        s2, noise = 1.0, "uncertainties"
    elif n > k:
        s2, noise = float(r @ r) / (n - k), "residuals"
    else:
        s2, noise = math.nan, "undetermined"
    cov = s2 * np.linalg.inv(Jw.T @ Jw)
    se = np.sqrt(np.abs(np.diag(cov)))
    fitted = {f: float(v) for f, v in zip(free, x)}
    sheet_fit = sheet.replace(**{f: v for f, v in fitted.items() if f != "gravity"})
    return Calibration(parameters=free, values=tuple(float(v) for v in x),
                       standard_errors=tuple(float(v) for v in se),
                       covariance=tuple(tuple(float(c) for c in row) for row in cov),
                       initial=tuple(float(v) for v in x0), measurements=ms,
                       model_deflections=tuple(float(v) for v in d),
                       residuals=tuple(float(v) for v in d - measured), branches=branches,
                       sheet=sheet_fit, gravity=fitted.get("gravity", gravity), path=path,
                       hmax=hmax, solves=model.solves, evaluations=len(model.cache),
                       converged=bool(res.success), message=str(res.message), noise=noise,
                       wall_time_s=time.perf_counter() - t0)
