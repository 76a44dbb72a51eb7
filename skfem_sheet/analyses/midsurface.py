"""The deformed mid-surface in the ribbon model's frame: u, v, w, strains and stresses.

Supplement, "Reduced-order theory: large plate rotations" (the kinematics) and
"Motivation/validation of reduced-order ansatzes" (Figs. S3, S4).  The flat
sheet's mid-surface ``z = 0`` is parametrised by the arclength ``s = x`` along
the centreline and ``t = y`` across it, ``t in [-p(s)/2, p(s)/2]``.  Its
deformed position is ``x(s, t) = X + U(X)`` at ``X = (s, t, 0)``.  The ribbon
model writes it in the frame of the cross-section's centre of mass::

    r(s)  = mean_t x(s, t),                      (centre of mass)
    r'(s) = (1 + eps(s)) d1(s),                  (centre-line strain eps)
    d1 = cos(phi) e1 + sin(phi) e3,  d2 = e2,  d3 = -sin(phi) e1 + cos(phi) e3,
    x(s, t) = r(s) + u d1 + (t + v) d2 + w d3,

so that ``u, v, w`` are the mid-surface displacements relative to the
cross-section's rigid motion (translation ``r``, rotation ``phi`` about
``e2``), each of zero cross-sectional mean.  ``mean_t`` is the average over
the width (``(1/p) int_{-p/2}^{p/2} dt``, Simpson's rule on the grid across,
:data:`N_ACROSS` points by default); ``r'(s)`` is the mean of ``dx/ds``
(the FE gradient, not a finite difference).

Strains and stresses
--------------------
The Green--Lagrange strains of the mid-surface in the (s, t) coordinates,
``E_ij = (d_i x . d_j x - delta_ij) / 2`` (eq. of E_ij), are the in-plane
components of ``(F^T F - I)/2`` on the mid-plane ``z = 0`` (continuous
across element faces there), independent of the frame.

The in-plane stresses are the paper's: the plate's stretching stress
resultants ``T_ij = Y [(1 - nu) E_ij + nu E_kk delta_ij]`` with the stretching
modulus ``Y = E h / (1 - nu^2)`` and ``nu = 1/2`` (supplement, eq. T_ij), the
small-strain limit of the incompressible neo-Hookean sheet in plane stress
(``Y = 4 mu h``), returned divided by ``Y``: ``T_ss / Y = E_ss + nu E_tt``,
``T_tt / Y = E_tt + nu E_ss``.

A symmetric half solve (mesh ``y >= 0``) is mirrored: ``U_x, U_z`` are even in
``t`` and ``U_y`` odd.  Trapezoids and planforms without bites are supported
(a cross-section is then one interval).

Example
-------
>>> from skfem_sheet import Sheet, solve
>>> r = solve(Sheet(length=1.0, curvature=0.5), hmax=0.2, gravity=0.0)
>>> m = midsurface(r.problem, r.w, [0.0, 0.5], n_across=21)
>>> m.w.shape
(2, 21)
>>> import numpy as np
>>> R, t = 2.0, m.t[0]                  # the clamp: v(0, t) = R sin(t/R) - t
>>> bool(abs(m.v[0] - (R * np.sin(t / R) - t)).max() < 1e-4)
True
"""
from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np

from ..io import register_point_fields
from ..params import POISSON_RATIO, ParameterError
from .transfer import ExtrudedLocator

__all__ = [
    "N_ACROSS",
    "VTU_NAMES",
    "Midsurface",
    "SectionFrame",
    "clamp_layer_width",
    "midsurface",
    "midsurface_at",
    "quadratic_fit",
    "section_frame",
    "vtu_fields",
]

#: Points across a cross-section (odd: Simpson's rule for the mean).
N_ACROSS = 81

#: Relative pull of points on the sheet's side into it (round-off on the boundary).
_INSIDE = 1e-10


# -- evaluation of the FE field on the mid-plane -----------------------------------------
#: point locators per mesh (a stretched problem shares its mesh's)
_LOCATORS = weakref.WeakKeyDictionary()


def _locator(problem):
    mesh = problem.sheet_mesh
    locator = _LOCATORS.get(mesh)
    if locator is None:
        locator = ExtrudedLocator.of(mesh, problem.space.basis_u.mapping)
        _LOCATORS[mesh] = locator
    return locator


def _deformation(problem, w, s, t):
    """Position ``x = X + U`` and gradient ``F = I + grad U`` at ``X = (s, t, 0)``.

    ``s, t`` are 1D arrays of one length (reference coordinates of the sheet,
    i.e. of the stretched mesh for ``problem.with_length``).  Returns ``x``
    (n, 3) and ``F`` (n, 3, 3) with ``F[:, i, j] = d x_i / d X_j``.
    """
    s = np.asarray(s, dtype=float)
    t = np.asarray(t, dtype=float)
    mesh = problem.sheet_mesh
    scale = problem.length / mesh.length  # stretch of the mesh in x
    mirror = mesh.half & (t < 0)
    ta = np.where(mirror, -t, t) if mesh.half else t
    X = np.column_stack([s / scale, ta, np.zeros_like(s)])
    basis = problem.space.basis_u
    cells = _locator(problem).locate(X)
    U, _ = problem.split(w)
    pts = basis.mapping.invF(X.T[:, :, None], tind=cells)
    u = np.zeros((len(s), 3))
    G = np.zeros((len(s), 3, 3))  # G[:, i, j] = d U_i / d X_j (mesh coordinates)
    for k in range(basis.Nbfun):
        field = basis.elem.gbasis(basis.mapping, pts, k, tind=cells)[0]
        phi = np.asarray(field)[:, 0]
        dphi = np.asarray(field.grad)[:, :, 0].T  # (n, 3)
        Uk = U[basis.element_dofs[k, cells]]  # (n, 3)
        u += phi[:, None] * Uk
        G += Uk[:, :, None] * dphi[:, None, :]
    G[:, :, 0] /= scale
    x = np.column_stack([s, ta, np.zeros_like(s)]) + u
    F = G + np.eye(3)
    if mesh.half:
        M = np.array([1.0, -1.0, 1.0])
        x[mirror] *= M
        F[mirror] = M[None, :, None] * F[mirror] * M[None, None, :]
        # on the symmetry plane the one-sided gradient of the half mesh has odd parts
        # (d U_x/dy, ...) that the mirrored side cancels: take the mean of both sides
        plane = t == 0
        F[plane] = 0.5 * (F[plane] + M[None, :, None] * F[plane] * M[None, None, :])
    return x, F


def _check_sections(problem, s):
    sheet = problem.sheet
    if getattr(sheet, "planform", None) is not None and sheet.planform.bites:
        raise ParameterError("the sheet must have no planform bites for mid-surface "
                             "observables (a cross-section must be one interval)")
    s = np.atleast_1d(np.asarray(s, dtype=float))
    L = problem.length
    if s.ndim != 1 or len(s) == 0 or not np.all(np.isfinite(s)):
        raise ParameterError(f"s must be a non-empty list of finite positions, got {s!r}")
    if np.any(s < 0) or np.any(s > L * (1 + 1e-12)):
        raise ParameterError(f"s must lie in [0, length = {L:g}], got {s.min():g} to {s.max():g}")
    s = np.clip(s, 0.0, L)
    p = np.asarray(sheet.width(s), dtype=float) * np.ones_like(s)
    if np.any(p <= 0):
        raise ParameterError(f"s must be where the sheet has a width, p(s) = 0 at s = "
                             f"{s[np.argmin(p)]:g}")
    return s, p


def _simpson_weights(n):
    """Weights of the composite Simpson rule on ``n`` (odd) equal intervals of [-1, 1],
    normalised to sum 1 (a mean)."""
    wts = np.ones(n)
    wts[1:-1:2] = 4.0
    wts[2:-1:2] = 2.0
    return wts / wts.sum()


def _check_across(n_across):
    if isinstance(n_across, bool) or not float(n_across).is_integer() or n_across < 5 \
            or int(n_across) % 2 == 0:
        raise ParameterError(f"n_across must be an odd integer >= 5, got {n_across!r}")
    return int(n_across)


# -- the frame of the cross-sections ------------------------------------------------------
@dataclass(frozen=True)
class SectionFrame:
    """Centre of mass and frame of the deformed cross-sections ``s``.

    Attributes
    ----------
    s : ndarray (n,)
        Reference positions of the sections (arclength of the flat sheet).
    width : ndarray (n,)
        p(s).
    centre : ndarray (n, 3)
        r(s), the cross-sectional mean of the deformed mid-surface.
    tangent : ndarray (n, 3)
        r'(s), the mean of ``dx/ds``.
    angle : ndarray (n,)
        phi(s) = atan2(r'_z, r'_x), the centre line's angle to e1 (positive up).
    strain : ndarray (n,)
        ``eps(s) = |r'| - 1``, the centre line's stretch.
    """

    s: np.ndarray
    width: np.ndarray
    centre: np.ndarray
    tangent: np.ndarray
    angle: np.ndarray
    strain: np.ndarray

    @property
    def d1(self):
        """Unit tangent d1(s), shape (n, 3)."""
        return np.column_stack([np.cos(self.angle), np.zeros_like(self.angle),
                                np.sin(self.angle)])

    @property
    def d3(self):
        """Normal d3(s) = d1 x d2, shape (n, 3)."""
        return np.column_stack([-np.sin(self.angle), np.zeros_like(self.angle),
                                np.cos(self.angle)])


@dataclass(frozen=True)
class Midsurface:
    """The deformed mid-surface on a structured (s, t) grid, in the sections' frame.

    Arrays of shape ``(n_sections, n_across)`` are indexed ``[section, point]``;
    ``t[i]`` runs from ``-p(s_i)/2`` to ``p(s_i)/2``.  Lengths are in units of
    the base width a.

    Attributes
    ----------
    frame : SectionFrame
    t : ndarray
        Reference coordinate across.
    position : ndarray (n_sections, n_across, 3)
        x(s, t).
    u, v, w : ndarray
        Displacements along d1, d2 and d3 relative to the section's rigid
        motion (zero cross-sectional means).
    E_ss, E_st, E_tt : ndarray
        Green--Lagrange strains of the mid-surface.
    thickness : float
        h/a of the sheet (for the scaled u/(h/a)^2, w/(h/a)).
    poisson_ratio : float
    """

    frame: SectionFrame
    t: np.ndarray
    position: np.ndarray
    u: np.ndarray
    v: np.ndarray
    w: np.ndarray
    E_ss: np.ndarray
    E_st: np.ndarray
    E_tt: np.ndarray
    thickness: float
    poisson_ratio: float = POISSON_RATIO

    @property
    def s(self):
        """Reference positions of the sections."""
        return self.frame.s

    @property
    def T_ss(self):
        """T_ss / Y = E_ss + nu E_tt (the paper's plate stress over Y = E h/(1 - nu^2))."""
        return self.E_ss + self.poisson_ratio * self.E_tt

    @property
    def T_tt(self):
        """T_tt / Y = E_tt + nu E_ss."""
        return self.E_tt + self.poisson_ratio * self.E_ss

    @property
    def T_st(self):
        """T_st / Y = (1 - nu) E_st."""
        return (1.0 - self.poisson_ratio) * self.E_st

    def scaled(self):
        """``(u/(h/a)^2, v/(h/a)^2, w/(h/a))``, the scaling of Fig. S4."""
        H = self.thickness
        return self.u / H**2, self.v / H**2, self.w / H

    def quadratic_fit(self):
        """Least-squares quadratics ``w = c0 + c1 t + c2 t^2`` per section.

        Returns
        -------
        coefficients : ndarray (n_sections, 3)
            ``c0, c1, c2``; ``2 c2`` is the lateral curvature c(s) of the
            ansatz ``w = W + c t^2/2``.
        residual : ndarray (n_sections,)
            Relative residual ``||w - fit|| / ||w||`` on the grid.
        """
        out = [quadratic_fit(t, w) for t, w in zip(self.t, self.w)]
        return np.array([c for c, _ in out]), np.array([r for _, r in out])

    def lateral_curvature(self):
        """c(s) = 2 c2 of :meth:`quadratic_fit`."""
        return 2.0 * self.quadratic_fit()[0][:, 2]


def quadratic_fit(t, w):
    """Least-squares quadratic in ``t`` and its relative residual.

    Parameters
    ----------
    t, w : array_like (n,)

    Returns
    -------
    coefficients : ndarray (3,)
        ``c0, c1, c2`` of ``c0 + c1 t + c2 t^2``.
    residual : float
        ``||w - fit||_2 / ||w||_2`` (0 for ``w = 0``).

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(-0.5, 0.5, 11)
    >>> c, r = quadratic_fit(t, 1 + t**2)
    >>> bool(np.allclose(c, [1, 0, 1]) and r < 1e-12)
    True
    """
    t = np.asarray(t, dtype=float)
    w = np.asarray(w, dtype=float)
    if t.shape != w.shape or t.ndim != 1 or len(t) < 3:
        raise ParameterError(f"t and w must be 1D arrays of one length >= 3, got shapes "
                             f"{t.shape} and {w.shape}")
    A = np.column_stack([np.ones_like(t), t, t**2])
    c, *_ = np.linalg.lstsq(A, w, rcond=None)
    norm = float(np.linalg.norm(w))
    res = float(np.linalg.norm(w - A @ c)) / norm if norm > 0 else 0.0
    return c, res


def _grid(problem, w, s, n_across):
    s, p = _check_sections(problem, s)
    tau = np.linspace(-1.0, 1.0, n_across) * (1.0 - _INSIDE)
    t = 0.5 * p[:, None] * tau[None, :]
    S = np.repeat(s[:, None], n_across, axis=1)
    x, F = _deformation(problem, w, S.ravel(), t.ravel())
    shape = (len(s), n_across)
    return s, p, t, x.reshape(shape + (3,)), F.reshape(shape + (3, 3))


def _frame(s, p, x, F, n_across):
    wts = _simpson_weights(n_across)
    centre = np.einsum("j,ijk->ik", wts, x)
    tangent = np.einsum("j,ijk->ik", wts, F[:, :, :, 0])
    angle = np.arctan2(tangent[:, 2], tangent[:, 0])
    strain = np.linalg.norm(tangent, axis=1) - 1.0
    return SectionFrame(s=s, width=p, centre=centre, tangent=tangent, angle=angle,
                        strain=strain)


def section_frame(problem, w, s, n_across: int = N_ACROSS) -> SectionFrame:
    """Centre of mass r(s), tangent r'(s), angle phi(s) and strain eps(s) of sections.

    Parameters
    ----------
    problem : SheetProblem
    w : ndarray
        A state of ``problem`` (e.g. ``Result.w``).
    s : array_like
        Reference positions in ``[0, length]``.
    n_across : int
        Points across each section for the means (odd, Simpson's rule).

    Returns
    -------
    SectionFrame

    Examples
    --------
    >>> from skfem_sheet import Sheet, solve
    >>> r = solve(Sheet(length=1.0, curvature=0.5), hmax=0.2, gravity=0.0)
    >>> f = section_frame(r.problem, r.w, [0.0, 1.0])
    >>> bool(abs(f.angle[0]) < 0.01 and f.angle[1] < 0)   # horizontal clamp; tip tilts down
    True
    """
    n_across = _check_across(n_across)
    s, p, _, x, F = _grid(problem, w, s, n_across)
    return _frame(s, p, x, F, n_across)


def _components(frame, t, x, F):
    """u, v, w and E_ss, E_st, E_tt from positions and gradients (leading axis: sections)."""
    rel = x - frame.centre[:, None, :]
    d1, d3 = frame.d1[:, None, :], frame.d3[:, None, :]
    u = np.sum(rel * d1, axis=-1)
    v = rel[..., 1] - t
    w = np.sum(rel * d3, axis=-1)
    xs, xt = F[..., :, 0], F[..., :, 1]
    E_ss = 0.5 * (np.sum(xs * xs, axis=-1) - 1.0)
    E_tt = 0.5 * (np.sum(xt * xt, axis=-1) - 1.0)
    E_st = 0.5 * np.sum(xs * xt, axis=-1)
    return u, v, w, E_ss, E_st, E_tt


def midsurface(problem, w, s, n_across: int = N_ACROSS) -> Midsurface:
    """The deformed mid-surface at the sections ``s``, ``n_across`` points across each.

    Parameters
    ----------
    problem : SheetProblem
        ``Result.problem``.
    w : ndarray
        ``Result.w``.
    s : array_like
        Reference positions of the sections, in ``[0, length]``.
    n_across : int
        Points across each section, ``t = linspace(-p/2, p/2, n_across)``
        (odd, at least 5; default :data:`N_ACROSS`).

    Returns
    -------
    Midsurface

    Raises
    ------
    ParameterError
        For ``s`` outside the sheet, an even or small ``n_across``, or a
        planform with bites.

    Examples
    --------
    >>> from skfem_sheet import Sheet, solve
    >>> r = solve(Sheet(length=1.0, curvature=0.5), hmax=0.2, gravity=0.0)
    >>> m = midsurface(r.problem, r.w, [0.5], n_across=21)
    >>> bool(abs(m.w[0] - m.w[0][::-1]).max() < 1e-12)   # symmetric in t
    True
    """
    n_across = _check_across(n_across)
    s, p, t, x, F = _grid(problem, w, s, n_across)
    frame = _frame(s, p, x, F, n_across)
    u, v, ww, E_ss, E_st, E_tt = _components(frame, t, x, F)
    return Midsurface(frame=frame, t=t, position=x, u=u, v=v, w=ww, E_ss=E_ss, E_st=E_st,
                      E_tt=E_tt, thickness=float(problem.sheet.thickness))


def midsurface_at(problem, w, points, n_sections: int = 401, n_across: int = N_ACROSS):
    """Mid-surface fields at arbitrary plan points ``(s, t)`` (e.g. mesh vertices).

    The frame (r, phi) is computed at ``n_sections`` equally spaced sections
    and interpolated linearly in ``s`` (cubic-free, so the means stay exact
    at the sections); positions and strains are evaluated at the points.

    Parameters
    ----------
    problem : SheetProblem
    w : ndarray
    points : array_like (n, 2)
        Reference ``(s, t)`` of mid-plane points on the sheet.
    n_sections : int
        Sections of the interpolated frame (at least 2).
    n_across : int

    Returns
    -------
    dict
        Name -> ndarray (n,): ``u``, ``v``, ``w``, ``E_ss``, ``E_st``,
        ``E_tt``, ``T_ss_over_Y``, ``T_tt_over_Y``.

    Examples
    --------
    >>> from skfem_sheet import Sheet, solve
    >>> r = solve(Sheet(length=1.0, curvature=0.5), hmax=0.2, gravity=0.0)
    >>> f = midsurface_at(r.problem, r.w, [[0.5, 0.25], [0.5, -0.25]])
    >>> bool(abs(f["w"][0] - f["w"][1]) < 1e-12)
    True
    """
    points = np.asarray(points, dtype=float)
    if points.ndim != 2 or points.shape[1] != 2:
        raise ParameterError(f"points must have shape (n, 2), got {points.shape}")
    if isinstance(n_sections, bool) or not float(n_sections).is_integer() or n_sections < 2:
        raise ParameterError(f"n_sections must be an integer >= 2, got {n_sections!r}")
    n_across = _check_across(n_across)
    frame = section_frame(problem, w, np.linspace(0.0, problem.length, int(n_sections)),
                          n_across)
    s = np.clip(points[:, 0], 0.0, problem.length)
    p = np.asarray(problem.sheet.width(s), dtype=float) * np.ones_like(s)
    t = np.clip(points[:, 1], -p / 2, p / 2) * (1.0 - _INSIDE)
    x, F = _deformation(problem, w, s, t)

    def at(a):
        return np.interp(s, frame.s, a)

    local = SectionFrame(s=s, width=p, centre=np.column_stack([at(frame.centre[:, k])
                                                               for k in range(3)]),
                         tangent=np.column_stack([at(frame.tangent[:, k]) for k in range(3)]),
                         angle=at(frame.angle), strain=at(frame.strain))
    u, v, ww, E_ss, E_st, E_tt = (a[:, 0] for a in _components(local, t[:, None],
                                                                  x[:, None], F[:, None]))
    nu = POISSON_RATIO
    return {"u": u, "v": v, "w": ww, "E_ss": E_ss, "E_st": E_st, "E_tt": E_tt,
            "T_ss_over_Y": E_ss + nu * E_tt, "T_tt_over_Y": E_tt + nu * E_ss}


def clamp_layer_width(sheet) -> float:
    """Width of the clamp's boundary layer: ``ln(20) l``, ``l = sqrt(R h) / (3 (1 - nu^2))^(1/4)``.

    ``l`` is the decay length of the edge effect of a cylindrical shell of
    radius ``R`` and thickness ``h`` (the clamped arc is an edge of such a
    cylinder; disturbances decay like ``exp(-s/l)``, e.g. Timoshenko &
    Woinowsky-Krieger, *Theory of plates and shells*, section 114), and
    ``ln(20) l`` is where ``exp(-s/l)`` has fallen to 5% of its value at the
    clamp.  A criterion from the shell's two lengths, not a fitted number.

    Parameters
    ----------
    sheet : Sheet

    Returns
    -------
    float
        In units of a; ``0`` for a flat clamp (``a/R = 0``, no layer).

    Examples
    --------
    >>> from skfem_sheet import Sheet
    >>> round(clamp_layer_width(Sheet(length=1.5, curvature=0.5, thickness=0.03175)), 3)
    0.616
    """
    kappa = float(sheet.curvature)
    if kappa == 0:
        return 0.0
    nu = POISSON_RATIO
    ell = np.sqrt(float(sheet.thickness) / kappa) / (3.0 * (1.0 - nu**2)) ** 0.25
    return float(np.log(20.0) * ell)


# -- fields of the result VTU -------------------------------------------------------------
#: VTU names of the fields of :func:`midsurface_at`.
VTU_NAMES = {"u": "midsurface_u", "v": "midsurface_v", "w": "midsurface_w", "E_ss": "E_ss",
             "E_st": "E_st", "E_tt": "E_tt", "T_ss_over_Y": "T_ss_over_Y",
             "T_tt_over_Y": "T_tt_over_Y"}


def vtu_fields(problem, w, points):
    """The mid-surface fields at the VTU's vertices ``points`` (3, n), by their plan position.

    Registered with :func:`skfem_sheet.io.register_point_fields`, so that
    ``Result.write("sheet.vtu")`` carries them (constant through the
    thickness: every vertex shows the value of the mid-surface point above or
    below it).  Nothing (``{}``) for a planform with bites.
    """
    sheet = problem.sheet
    if getattr(sheet, "planform", None) is not None and sheet.planform.bites:
        return {}
    xy = np.asarray(points, dtype=float)[:2].T
    plan, inverse = np.unique(np.round(xy, 12), axis=0, return_inverse=True)
    fields = midsurface_at(problem, w, plan)
    return {VTU_NAMES[k]: v[inverse.ravel()] for k, v in fields.items()}


register_point_fields(vtu_fields)
