"""The reduced model's ansatz against the 3D solution (issue 27; supplement Figs. S3, S4).

    python benchmarks/ansatz.py [--hmax 0.03] [--thickness 0.03175] [--second-thickness 0.02]
        [--json out.json] [--txt out.txt]
    python benchmarks/ansatz.py --residual-study [--json out.json] [--txt out.txt]

Supplement, "Motivation/validation of reduced-order ansatzes": without
gravity, a rectangle clamped on an arc (a/R = 0.5, h/a = 0.03175) has

- (Fig. S4, L/a = 2) a mid-surface deflection w (normal to the centre line,
  relative to the cross-section's rigid motion) that is quadratic in t at
  leading order, and in-plane displacements u, v of order (h/a)^2;
- (Fig. S3, L/a = 1.5) small in-plane strains save for a boundary layer at
  the clamp.

Measured here, with :mod:`skfem_sheet.analyses.midsurface` on ``solve(sheet,
gravity=0.0)`` (curvature-first, the symmetric half, the default start):

- per section s/a in {0.4, 0.8, 1.2} of the S4 sheet:
  ``w_quadratic_residual`` = ||w - q|| / ||w|| for the least-squares
  quadratic q in t over the full width (81 equally spaced points); also the
  residual of an even quartic ``c0 + c2 t^2 + c4 t^4`` (``w_quartic_residual``:
  what the quadratic misses), ``u_scaled_max`` = max |u| / (h/a)^2,
  ``v_scaled_max`` = max |v| / (h/a)^2, ``w_scaled_max`` = max |w| / (h/a);
- on the S3 sheet: ``strain_max_outside_layer``, the largest of |E_ss|,
  |E_st|, |E_tt| over s >= ``layer_width`` (41 sections from there to the
  tip), and ``strain_max_in_layer`` over s < layer_width (41 sections).  The
  layer's width is a criterion, not a fit: ``ln(20) l`` with the edge-effect
  length of a cylindrical shell ``l = sqrt(R h) / (3 (1 - nu^2))^(1/4)``
  (where ``exp(-s/l)`` has decayed to 5%;
  :func:`skfem_sheet.analyses.midsurface.clamp_layer_width`);
- with a second thickness (default h/a = 0.02, same mesh size): the exponent
  p of max|u| and max|v| ~ (h/a)^p at each section (``inplane_exponents``),
  and one common exponent fitted to all six (separate prefactors; least
  squares in logs) with its standard error, ``inplane_exponent`` and
  ``inplane_exponent_uncertainty``.  With two thicknesses each per-series
  exponent is exact and the common fit's residual is the series' spread.
  At a fixed a/R the clamp sets u and v (``v(0, t) = -t^3/(6 R^2)``), so the
  same fit is repeated with a/R in proportion to h/a (the ansatz's scaling
  ``w ~ a (h/a)``, i.e. ``c ~ (h/a)/a``, which also keeps the persistence
  length a^2/sqrt(70 h R)): ``inplane_exponent_similar``.

``--residual-study``: w's quadratic residual of the S4 sections on three
meshes (0.045, 0.03, 0.02), for thinner sheets (h/a 0.02, 0.01) at a/R 0.5
and with a/R in proportion to h/a, and at small clamp curvatures (a/R 0.1,
0.02: the linear limit) -- whether the residual is the mesh's, and whether it
vanishes in any limit of the ansatz (:data:`RESIDUAL_STUDY`).

Defaults are the paper's parameters at the paper's mesh (hmax 0.03); the
default-suite tests (``tests/test_supplement.py``) run the same functions at
hmax 0.1.
"""
from __future__ import annotations

import math
import sys
import time

import numpy as np

from skfem_sheet import Sheet, solve
from skfem_sheet.analyses.midsurface import clamp_layer_width, midsurface
from skfem_sheet.io import atomic_write, dumps_json

from harness import parser

SECTIONS = (0.4, 0.8, 1.2)
CURVATURE = 0.5
THICKNESS = 0.03175
S3_LENGTH = 1.5
S4_LENGTH = 2.0
N_ACROSS = 81


def even_quartic_residual(t, w):
    """||w - q4|| / ||w|| for the least-squares ``c0 + c2 t^2 + c4 t^4``."""
    A = np.column_stack([np.ones_like(t), t**2, t**4])
    c, *_ = np.linalg.lstsq(A, w, rcond=None)
    return float(np.linalg.norm(w - A @ c) / np.linalg.norm(w))


def s4_sections(thickness=THICKNESS, hmax=0.03, sections=SECTIONS, curvature=CURVATURE):
    """Per-section measures of the S4 sheet (list of dicts) and the solve's record."""
    sheet = Sheet(length=S4_LENGTH, curvature=curvature, thickness=thickness)
    result = solve(sheet, hmax=hmax, gravity=0.0)
    m = midsurface(result.problem, result.w, list(sections), n_across=N_ACROSS)
    us, vs, ws = m.scaled()
    _, res = m.quadratic_fit()
    rows = []
    for i, s in enumerate(m.s):
        rows.append({
            "s": float(s),
            "w_quadratic_residual": float(res[i]),
            "w_quartic_residual": even_quartic_residual(m.t[i], m.w[i]),
            "lateral_curvature": float(m.lateral_curvature()[i]),
            "u_scaled_max": float(np.abs(us[i]).max()),
            "v_scaled_max": float(np.abs(vs[i]).max()),
            "w_scaled_max": float(np.abs(ws[i]).max()),
            "u_max": float(np.abs(m.u[i]).max()),
            "v_max": float(np.abs(m.v[i]).max()),
            "angle": float(m.frame.angle[i]),
        })
    return rows, result


def s3_strains(thickness=THICKNESS, hmax=0.03, n_sections=41):
    """Largest in-plane strain inside and outside the clamp layer of the S3 sheet."""
    sheet = Sheet(length=S3_LENGTH, curvature=CURVATURE, thickness=thickness)
    result = solve(sheet, hmax=hmax, gravity=0.0)
    width = clamp_layer_width(sheet)

    def largest(s):
        m = midsurface(result.problem, result.w, s, n_across=N_ACROSS)
        E = np.maximum(np.maximum(np.abs(m.E_ss), np.abs(m.E_st)), np.abs(m.E_tt))
        i, j = np.unravel_index(np.argmax(E), E.shape)
        return float(E[i, j]), float(m.s[i]), float(m.t[i, j])

    outside = largest(np.linspace(width, S3_LENGTH, n_sections))
    inside = largest(np.linspace(0.0, width, n_sections, endpoint=False))
    return {"layer_width": width, "strain_max_outside_layer": outside[0],
            "strain_max_outside_at": [outside[1], outside[2]],
            "strain_max_in_layer": inside[0], "strain_max_in_layer_at": [inside[1], inside[2]],
            "strain_outside_over_H2": outside[0] / thickness**2,
            "bending_strain_scale": thickness * CURVATURE / 2}, result


def exponent_fit(thicknesses, series):
    """Common exponent p of ``q_k(H) = A_k H^p`` over the series (least squares in logs).

    Parameters
    ----------
    thicknesses : sequence of float (m,)
    series : dict name -> sequence of m positive values

    Returns
    -------
    p, standard_error, per_series : float, float, dict
        ``standard_error`` is NaN when the fit has no residual degrees of freedom.
    """
    logH = np.log(np.asarray(thicknesses, dtype=float))
    names = list(series)
    rows, rhs = [], []
    for k, name in enumerate(names):
        for i, q in enumerate(series[name]):
            row = np.zeros(len(names) + 1)
            row[0], row[1 + k] = logH[i], 1.0
            rows.append(row)
            rhs.append(math.log(q))
    A, b = np.array(rows), np.array(rhs)
    x, *_ = np.linalg.lstsq(A, b, rcond=None)
    dof = len(b) - A.shape[1]
    per = {}
    for name in names:
        q = np.log(np.asarray(series[name], dtype=float))
        per[name] = float(np.polyfit(logH, q, 1)[0])
    if dof <= 0:
        return float(x[0]), float("nan"), per
    sigma2 = float(np.sum((A @ x - b) ** 2)) / dof
    cov = sigma2 * np.linalg.inv(A.T @ A)
    return float(x[0]), float(math.sqrt(cov[0, 0])), per


def run(hmax=0.03, thickness=THICKNESS, second=0.02):
    t0 = time.perf_counter()
    rows, r4 = s4_sections(thickness, hmax)
    strains, r3 = s3_strains(thickness, hmax)
    out = {"case": {"curvature": CURVATURE, "thickness": thickness, "hmax": hmax,
                    "gravity": 0.0, "s4_length": S4_LENGTH, "s3_length": S3_LENGTH,
                    "path": r4.path, "n_across": N_ACROSS},
           "dofs": {"s4": r4.dofs, "s3": r3.dofs}, "layers": {"s4": r4.layers, "s3": r3.layers},
           "sections": rows, **strains}
    if second:
        rows2, r42 = s4_sections(second, hmax)
        series = {}
        for a, b in zip(rows, rows2):
            for comp in ("u", "v"):
                series[f"{comp}@s={a['s']:g}"] = [a[f"{comp}_max"], b[f"{comp}_max"]]
        p, err, per = exponent_fit([thickness, second], series)
        out.update({"second_thickness": second, "second_sections": rows2,
                    "inplane_exponent": p, "inplane_exponent_uncertainty": err,
                    "inplane_exponents": per, "dofs_second": r42.dofs})
        # the ansatz's scaling (w ~ a H, so c ~ H/a): a/R in proportion to h/a, which
        # keeps the persistence length a^2/sqrt(70 h R) and so the sections' places
        kappa = CURVATURE * second / thickness
        rows3, _ = s4_sections(second, hmax, curvature=kappa)
        series = {}
        for a, b in zip(rows, rows3):
            for comp in ("u", "v"):
                series[f"{comp}@s={a['s']:g}"] = [a[f"{comp}_max"], b[f"{comp}_max"]]
        p, err, per = exponent_fit([thickness, second], series)
        out.update({"similar_curvature": kappa, "similar_sections": rows3,
                    "inplane_exponent_similar": p,
                    "inplane_exponent_similar_uncertainty": err,
                    "inplane_exponents_similar": per})
    out["wall_time_s"] = time.perf_counter() - t0
    return out


def table(out) -> str:
    H = out["case"]["thickness"]
    lines = [f"ansatz check: rectangle, a/R = {out['case']['curvature']}, h/a = {H}, no gravity, "
             f"hmax {out['case']['hmax']} ({out['dofs']['s4']} unknowns at L/a 2, "
             f"{out['layers']['s4']} layers)",
             "",
             "S4 (L/a = 2):   s/a  w quad. resid  w quartic resid  max|u|/H^2  max|v|/H^2  "
             "max|w|/H   c(s) a",
             "-" * 96]
    for r in out["sections"]:
        lines.append(f"               {r['s']:4.2f}  {r['w_quadratic_residual']:13.4f}  "
                     f"{r['w_quartic_residual']:15.4f}  {r['u_scaled_max']:10.3f}  "
                     f"{r['v_scaled_max']:10.3f}  {r['w_scaled_max']:8.3f}  "
                     f"{r['lateral_curvature']:7.4f}")
    lines += ["",
              f"S3 (L/a = 1.5): clamp layer s/a < {out['layer_width']:.3f} "
              f"(ln 20 sqrt(R h)/(3(1-nu^2))^(1/4))",
              f"  largest |E| outside the layer: {out['strain_max_outside_layer']:.3e} at (s, t) = "
              f"({out['strain_max_outside_at'][0]:.3f}, {out['strain_max_outside_at'][1]:+.3f}) "
              f"= {out['strain_outside_over_H2']:.2f} (h/a)^2",
              f"  largest |E| inside the layer:  {out['strain_max_in_layer']:.3e} at (s, t) = "
              f"({out['strain_max_in_layer_at'][0]:.3f}, {out['strain_max_in_layer_at'][1]:+.3f})",
              f"  (surface bending strain h/(2R) = {out['bending_strain_scale']:.3e})"]
    if "inplane_exponent" in out:
        lines += ["",
                  f"in-plane exponent from h/a = {H} and {out['second_thickness']}: "
                  f"p = {out['inplane_exponent']:.3f} +- {out['inplane_exponent_uncertainty']:.3f} "
                  f"(common fit, standard error; the paper's ansatz: 2)",
                  "  per series: " + ", ".join(f"{k} {v:.2f}"
                                               for k, v in out["inplane_exponents"].items()),
                  f"with a/R in proportion to h/a (a/R = {out['similar_curvature']:.4f} at h/a "
                  f"{out['second_thickness']}; the ansatz's scaling, same persistence length): "
                  f"p = {out['inplane_exponent_similar']:.3f} +- "
                  f"{out['inplane_exponent_similar_uncertainty']:.3f}",
                  "  per series: " + ", ".join(
                      f"{k} {v:.2f}" for k, v in out["inplane_exponents_similar"].items())]
    lines.append(f"\nwall time {out['wall_time_s']:.1f} s")
    return "\n".join(lines)


#: The residual study: (h/a, hmax, a/R) of each S4 solve.  The paper's case on
#: three meshes (is the residual the mesh's?), thinner sheets at the same a/R
#: and with a/R in proportion to h/a (the ansatz's limit H -> 0), and small
#: clamp curvatures (the linear limit).
RESIDUAL_STUDY = ((THICKNESS, 0.045, CURVATURE), (THICKNESS, 0.03, CURVATURE),
                  (THICKNESS, 0.02, CURVATURE),
                  (0.02, 0.03, CURVATURE), (0.01, 0.03, CURVATURE),
                  (0.02, 0.03, CURVATURE * 0.02 / THICKNESS),
                  (0.01, 0.03, CURVATURE * 0.01 / THICKNESS),
                  (THICKNESS, 0.03, 0.1), (THICKNESS, 0.03, 0.02))


def residual_study(cases=RESIDUAL_STUDY):
    """w's quadratic residual at the S4 sections against the mesh, the
    thickness and the clamp curvature: one row per case (``thickness``,
    ``hmax``, ``curvature``, ``dofs``, and per section ``w_quadratic_residual``,
    ``w_quartic_residual``, ``lateral_curvature``)."""
    out = []
    for H, h, kappa in cases:
        t0 = time.perf_counter()
        rows, result = s4_sections(H, h, curvature=kappa)
        out.append({"thickness": H, "hmax": h, "curvature": kappa, "dofs": result.dofs,
                    "sections": [{k: r[k] for k in ("s", "w_quadratic_residual",
                                                    "w_quartic_residual", "lateral_curvature")}
                                 for r in rows],
                    "wall_time_s": time.perf_counter() - t0})
    return out


def study_table(rows) -> str:
    s = [f"{x['s']:g}" for x in rows[0]["sections"]]
    lines = ["w's relative residual from a least-squares quadratic in t over the full width "
             "(S4 rectangle, L/a 2, no gravity),",
             "against the mesh, the thickness and the clamp curvature",
             "",
             f"  h/a      hmax    a/R     dofs   quadratic resid. at s/a {', '.join(s):<14}"
             f"  even quartic resid.   c(s) a",
             "-" * 110]
    for r in rows:
        q = " ".join(f"{x['w_quadratic_residual']:.4f}" for x in r["sections"])
        q4 = " ".join(f"{x['w_quartic_residual']:.4f}" for x in r["sections"])
        c = " ".join(f"{x['lateral_curvature']:.4f}" for x in r["sections"])
        lines.append(f"  {r['thickness']:<7g}  {r['hmax']:<5g}  {r['curvature']:<6.4g} "
                     f"{r['dofs']:7d}   {q:<38} {q4:<21} {c}")
    return "\n".join(lines)


def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument("--hmax", type=float, default=0.03)
    ap.add_argument("--thickness", type=float, default=THICKNESS)
    ap.add_argument("--second-thickness", type=float, default=0.02,
                    help="second h/a for the in-plane exponent (0: none)")
    ap.add_argument("--residual-study", action="store_true",
                    help="instead: w's quadratic residual against the mesh, the thickness and "
                         "the clamp curvature (RESIDUAL_STUDY; about 3 min)")
    ap.add_argument("--json", default=None)
    ap.add_argument("--txt", default=None)
    args = ap.parse_args(argv)
    if args.residual_study:
        out = {"cases": residual_study()}
        text = study_table(out["cases"])
    else:
        out = run(args.hmax, args.thickness, args.second_thickness or None)
        text = table(out)
    print(text)
    if args.json:
        atomic_write(args.json, dumps_json(out) + "\n")
    if args.txt:
        atomic_write(args.txt, text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
