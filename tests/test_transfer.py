"""Transfer between meshes (skfem_sheet.analyses.transfer): same values as
scikit-fem's probes, memory linear in the mesh, and no growth with the number
of continuation steps."""
import gc
import json
import os
import subprocess
import sys
import textwrap
import tracemalloc

import numpy as np
import pytest
from skfem import MeshTet

from skfem_sheet import Sheet
from skfem_sheet.analyses.transfer import (
    ExtrudedLocator,
    TransferError,
    _clip_to_sheet,
    carry_distance,
    interpolate,
    transfer,
)
from skfem_sheet.mesh import SheetMesh, sheet_mesh
from skfem_sheet.params import ParameterError, Planform
from skfem_sheet.problem import SheetProblem

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def probes_transfer(old, w_old, new):
    """The transfer before issue 19 (scikit-fem's element finder), verbatim."""
    s_old = old.length / old.sheet_mesh.length
    X = new.nodes / np.array([s_old, 1.0, 1.0])
    X = _clip_to_sheet(X, old.sheet_mesh)
    U_old, p_old = old.split(w_old)
    P2 = old.basis_u.probes(X.T)
    n_v = new.sheet_mesh.n_vertices
    P1 = old.basis_p.probes(X[:n_v].T)
    w = np.zeros(new.ndof)
    w[: new.nu_dof] = (P2 @ U_old).ravel()
    w[new.nu_dof:] = P1 @ p_old
    return w


def problem(length, tip_width, hmax, half, layers=None):
    s = Sheet(length=length, tip_width=tip_width)
    return SheetProblem(s, sheet_mesh(s, hmax, layers, half=half))


@pytest.mark.parametrize("tip_width", [1.0, 0.5, 0.0])
@pytest.mark.parametrize("half", [True, False])
def test_transfer_equals_probes_from_a_stretched_mesh(tip_width, half):
    """Stretched old mesh onto a fresh, finer one with other layers, in chunks
    that do not divide the nodes: the values of scikit-fem's probes to 1e-12
    (a random state: any cell containing a point gives the same value of the
    continuous field up to round-off, a wrong cell an O(1) error)."""
    old = problem(1.0, tip_width, 0.2, half).with_length(1.3)
    new = problem(1.3, tip_width, 0.15, half, layers=3)
    w = np.random.default_rng(1).standard_normal(old.ndof)
    np.testing.assert_allclose(transfer(old, w, new, chunk=97), probes_transfer(old, w, new),
                               rtol=0, atol=1e-12)


@pytest.mark.parametrize("half", [True, False])
def test_transfer_onto_the_same_mesh_at_its_nodes(half):
    """Every node of a mesh lies on a vertex or an edge of many cells (and the
    boundary nodes are clipped): the values agree with probes to 1e-12, and
    the transfer onto the mesh itself is the identity up to the clip."""
    p = problem(1.1, 0.4, 0.2, half)
    w = np.random.default_rng(2).standard_normal(p.ndof)
    got = transfer(p, w, p, chunk=50)
    np.testing.assert_allclose(got, probes_transfer(p, w, p), rtol=0, atol=1e-12)
    # the clip moves boundary nodes by 1e-12 relative: P2 gradients are O(1/h^2)
    np.testing.assert_allclose(got, w, rtol=0, atol=1e-9)


def test_clamped_values_are_copied():
    """With one hmax the clamped edge is meshed alike at every length: the
    clamped dofs of the new mesh get the clamp displacement of the arc (the
    values ``bistability`` had before), to the clip's 1e-12 relative shift."""
    s = Sheet(length=1.0, curvature=2.5)
    old = SheetProblem(s, sheet_mesh(s, 0.15, half=True)).with_length(1.3)
    new = problem(1.3, 1.0, 0.15, True)
    w = np.zeros(old.ndof)
    w[old.clamp_dofs] = old.clamp_values(2.5)
    got = transfer(old, w, new)[new.clamp_dofs]
    np.testing.assert_allclose(got, new.clamp_values(2.5), rtol=0, atol=1e-11)
    assert np.abs(got).max() > 0.05  # the arc is not trivial


def test_no_points():
    sm = sheet_mesh(Sheet(length=1.0), 0.25, half=True)
    assert ExtrudedLocator.of(sm).locate(np.zeros((0, 3))).shape == (0,)


def _special_points(sm, rng):
    """Vertices, edge midpoints, face centroids, random interior points and
    points on the outer surface of the mesh ``sm``, in mesh coordinates."""
    m = sm.mesh
    p, t = m.p, m.t
    edges = m.edges
    faces = m.facets
    pick = rng.choice(t.shape[1], 200)
    bary = rng.dirichlet(np.ones(4), 200)
    inner = np.einsum("ijk,kj->ik", p[:, t[:, pick]], bary)
    boundary = m.boundary_facets()
    bb = rng.dirichlet(np.ones(3), len(boundary))
    on_surface = np.einsum("ijk,kj->ik", p[:, m.facets[:, boundary]], bb)
    return np.hstack([p, p[:, edges].mean(axis=1), p[:, faces].mean(axis=1), inner,
                      on_surface]).T


@pytest.mark.parametrize("tip_width,half", [(1.0, True), (0.3, False), (0.0, True)])
def test_located_cell_contains_the_point(tip_width, half):
    """On vertices, edges, faces, the outer surface and inside: the cell found
    contains the point (barycentric coordinates >= -1e-12; scikit-fem's finder
    refuses some of the surface points, round-off outside by more than its
    machine-epsilon tolerance), and on the points clipped into the sheet as
    ``transfer`` does the interpolation is the probes' one."""
    s = Sheet(length=0.9, tip_width=tip_width)
    sm = sheet_mesh(s, 0.2, half=half)
    prob = SheetProblem(s, sm)
    X = _special_points(sm, np.random.default_rng(3))
    loc = ExtrudedLocator.of(sm)
    cells = loc.locate(X)
    R = prob.basis_u.mapping.invF(X.T[:, :, None], tind=cells)[:, :, 0]
    lam = np.vstack([R, 1 - R.sum(axis=0)])
    assert lam.min() >= -1e-12
    X = _clip_to_sheet(X, sm)
    cells = loc.locate(X)
    U = np.random.default_rng(4).standard_normal((prob.n_nodes, 3))
    np.testing.assert_allclose(interpolate(prob.basis_u, U, X, cells),
                               prob.basis_u.probes(X.T) @ U, rtol=0, atol=1e-12)
    pv = np.random.default_rng(5).standard_normal(prob.n_vertices)
    np.testing.assert_allclose(interpolate(prob.basis_p, pv, X, cells),
                               prob.basis_p.probes(X.T) @ pv, rtol=0, atol=1e-12)


def test_points_outside_the_mesh_are_refused():
    s = Sheet(length=1.0, tip_width=0.5)
    loc = ExtrudedLocator.of(sheet_mesh(s, 0.25, half=True))
    h = s.thickness
    for X in ([0.5, -0.01, 0.0],      # y < 0 of a half mesh
              [1.0, 0.3, 0.0],        # beyond the slanted edge (tip half-width 0.25)
              [1.2, 0.1, 0.0],        # beyond the tip
              [0.5, 0.1, 0.6 * h]):   # above the sheet
        with pytest.raises(ParameterError, match="outside"):
            loc.locate(np.array([X]))


def test_a_mesh_that_is_not_extruded_is_refused():
    """A free tetrahedral mesh, an extruded one with a vertex moved off its
    layer, and one declared with the wrong number of layers."""
    base = sheet_mesh(Sheet(length=1.0), 0.25, half=True)
    p = base.mesh.p.copy()
    p[2, 0] += 1e-3
    for m, layers in [(MeshTet.init_ball(1), 2), (MeshTet(p, base.mesh.t), base.layers),
                      (base.mesh, base.layers + 1)]:
        sm = SheetMesh(mesh=m, length=1.0, tip_width=1.0, thickness=0.03, hmax=0.25,
                       layers=layers)
        with pytest.raises(ParameterError, match="sheet_mesh must be extruded"):
            ExtrudedLocator.of(sm)
    with pytest.raises(ParameterError, match="chunk"):
        p = problem(1.0, 1.0, 0.25, True)
        transfer(p, np.zeros(p.ndof), p, chunk=0)


def _traced_peak(old, w, new):
    gc.collect()
    tracemalloc.start()
    try:
        transfer(old, w, new)
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_transfer_memory_is_linear_in_the_mesh():
    """The memory a transfer allocates (tracemalloc: numpy's buffers) per
    unknown of the new mesh does not grow with the mesh.  Between hmax 0.2 and
    0.1 the unknowns grow about 3.5x; scikit-fem's element finder allocates
    about ``3 x points x candidates`` doubles (measured: 16 MB at hmax 0.2 and
    200 MB at 0.1 in benchmarks/transfer_memory.py, 12x): its bytes per
    unknown grow 2.9x here.  Linear costs allow 1.5x (bin occupancy and the
    share of fixed overheads vary; measured 1.2x)."""
    per_dof = []
    for hmax in (0.2, 0.1):
        old = problem(1.8, 1.0, hmax, True).with_length(2.4)
        new = problem(2.4, 1.0, hmax, True)
        w = np.random.default_rng(6).standard_normal(old.ndof)
        per_dof.append(_traced_peak(old, w, new) / new.ndof)
    assert per_dof[1] <= 1.5 * per_dof[0], per_dof
    assert per_dof[1] < 400, per_dof  # bytes per unknown: 50 doubles


def test_repeated_transfers_do_not_accumulate_memory():
    """Remesh back and forth between two lengths (stretch, transfer, stretch
    back, transfer): after 3N cycles the allocated memory is that after N.
    Tolerance: one state vector (measured growth: about 2 kB of numpy's small
    internal allocations, a sixth of it); anything kept per transfer that is
    at least a state (a state, a locator, a problem) would add 12 of them."""
    a, b = problem(1.0, 1.0, 0.2, True), problem(1.3, 1.0, 0.2, True)
    w = np.random.default_rng(7).standard_normal(a.ndof)

    def cycles(n, w):
        for _ in range(n):
            wb = transfer(a.with_length(1.3), w, b)
            w = transfer(b.with_length(1.0), wb, a)
        return w

    w = cycles(2, w)  # warm up (lazily built mappings, interned objects)
    gc.collect()
    tracemalloc.start()
    try:
        w = cycles(3, w)
        gc.collect()
        after_n = tracemalloc.get_traced_memory()[0]
        w = cycles(6, w)
        gc.collect()
        after_3n = tracemalloc.get_traced_memory()[0]
    finally:
        tracemalloc.stop()
    assert after_3n - after_n <= 8 * a.ndof, (after_n, after_3n, 8 * a.ndof)


_CHILD = textwrap.dedent("""
    import gc, json, resource, sys, tracemalloc
    from skfem_sheet import Sheet
    from skfem_sheet.bistability import follow_length
    from skfem_sheet.mesh import sheet_mesh
    from skfem_sheet.problem import SheetProblem
    tracemalloc.start()
    sheet = Sheet(length=0.9, tip_width=0.0, curvature=2.5)
    b = follow_length(sheet, 1.5, hmax=0.2, step=float(sys.argv[1]))
    gc.collect()
    current, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    s = sheet.replace(length=1.5)
    prob = SheetProblem(s, sheet_mesh(s, 0.2, half=True))
    stretched = prob.with_length(1.45)  # what one continuation step builds
    step_bytes = sum(getattr(stretched.space, k).nbytes for k in ("dphi", "dx", "nodes", "laplacian"))
    print(json.dumps(dict(points=len(b.points), fold=b.fold, current=current, peak=peak,
                          rss_kb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
                          ndof=int(prob.ndof), step_bytes=int(step_bytes))))
""")


def _follow_in_child(step):
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=ROOT)
    out = subprocess.run([sys.executable, "-c", _CHILD, repr(step)], env=env, cwd=ROOT,
                         capture_output=True, text=True, check=True, timeout=600)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_memory_does_not_grow_with_the_number_of_continuation_steps():
    """follow_length of the triangle (a/R 2.5, hmax 0.2) from L/a 0.9 to 1.5
    in N = 10 and in 3N = 30 steps, each in a fresh process.  Both runs remesh
    once, at L/a 1.2 (the stretch limit 1.35 is passed at the step after 1.2
    on both step grids), so they build the same meshes, solve the same
    problems and transfer once: the memory must be the same.  Tolerances:

    - retained memory (tracemalloc, after the run; the package's bounded mesh
      and discretisation caches hold the same meshes in both runs): the 20
      extra branch points are small objects (measured: 10 kB in all);
      allowed is a quarter of one state vector per extra step (a state, a
      problem or a matrix kept per step is at least one state vector);
    - peak allocated memory (tracemalloc): the peak is set by the same
      largest problem in both runs (measured difference 40 kB, 0.2%); allowed
      is half of what one step builds (the stretched problem's basis
      gradients, weights, nodes and element Laplacians, 0.37 MB here):
      keeping those per step would add 20 of them;
    - peak RSS (getrusage): half of 20 such steps (3.6 MB), for allocator
      fragmentation and page-granular resident memory (measured difference
      below 0.1 MB).
    """
    n, n3 = _follow_in_child(0.06), _follow_in_child(0.02)
    assert (n["points"], n3["points"]) == (11, 31)  # the designed steps, no halving
    assert n["fold"] is None and n3["fold"] is None
    state = 8 * n["ndof"]
    assert n3["current"] - n["current"] <= 0.25 * state * 20, (n, n3)
    assert n3["peak"] - n["peak"] <= 0.5 * n["step_bytes"], (n, n3)
    assert n3["rss_kb"] - n["rss_kb"] <= 10 * n["step_bytes"] / 1024, (n, n3)


# -- meshes of a curved outline (issue 56) --------------------------------------------
FLARE = Planform.from_function(lambda s: 1 + 0.2 * s * s)      # the outline bulges inwards
LEAF = Planform.from_function(lambda s: 1 + 0.5 * s - 0.9 * s * s)  # ... and outwards


def _curved(planform, hmax, length=1.6):
    s = Sheet.from_planform(planform, length=length)
    return SheetProblem(s, sheet_mesh(s, hmax, half=True))


def test_the_chord_error_of_a_curved_outline_falls_with_the_square_of_the_mesh():
    """The sagitta of a chord of length h on a curve of curvature k is h^2 k / 8:
    halving hmax divides the chord error by about four (3.6 and 3.8 measured
    for the flare between hmax 0.2, 0.1 and 0.05: the edges are not all hmax
    long); the trapezoid's edges are straight, its meshes exact."""
    errors = [_curved(FLARE, h).sheet_mesh.chord_error for h in (0.2, 0.1, 0.05)]
    assert all(3.0 < a / b < 5.0 for a, b in zip(errors, errors[1:])), errors
    assert problem(1.6, 0.7, 0.1, True).sheet_mesh.chord_error == 0.0


@pytest.mark.parametrize("planform", [FLARE, LEAF], ids=["flare", "leaf"])
def test_a_quadratic_field_is_carried_exactly_between_meshes_of_a_curved_outline(planform):
    """A field quadratic in X is P2 on every cell, so its interpolation on the
    fine mesh is exact at every fine node: inside the coarse plan and also at
    the nodes just outside it (the flare's fine chord midpoints, the leaf's
    fine vertices on its outline), which take the nearest boundary cell's
    polynomial, the same quadratic.  Before issue 56 the flare's transfer
    refused those nodes, and the leaf's was clipped to the straight line
    between the clamp and the tip width (0.11 a inside the outline at
    mid-length).  Some nodes do lie outside here, each within the two meshes'
    chord errors."""
    coarse, fine = _curved(planform, 0.2), _curved(planform, 0.1)

    def field(X):
        x, y, z = X.T
        return np.stack([0.3 * x * y - 0.1 * z, 0.2 * x * x + 0.5 * y * z,
                         -0.4 * y * y + 0.1 * x + z * x], axis=1)

    w = coarse.space.join(field(coarse.nodes), np.zeros(coarse.n_vertices))
    got = transfer(coarse, w, fine)
    np.testing.assert_allclose(fine.split(got)[0], field(fine.nodes), rtol=0, atol=1e-12)
    locator = ExtrudedLocator.of(coarse.sheet_mesh)
    _, score = locator.locate_plan(fine.nodes[:, :2])
    outside = score < -1e-8
    assert outside.sum() > 0
    _, dist = locator.nearest_boundary(fine.nodes[outside, :2])
    assert dist.max() <= carry_distance(coarse.sheet_mesh, fine.sheet_mesh)


def test_a_node_farther_out_than_the_chord_errors_is_refused_naming_both_meshes():
    """Meshes of two different outlines (a flare onto a wider one): their
    nodes lie up to 0.05 a outside, far beyond the chord errors: a
    TransferError that names both meshes and the distance, not a crash."""
    old = _curved(FLARE, 0.2)
    new = _curved(Planform.from_function(lambda s: 1 + 0.3 * s * s), 0.1)
    with pytest.raises(TransferError, match=r"hmax 0\.2 .*hmax 0\.1 .*outside the plan of the "
                                            r"mesh by 0\.0[45]"):
        transfer(old, np.zeros(old.ndof), new)
