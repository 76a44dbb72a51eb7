"""Assembler: the sparsity pattern, the block assembly, threads."""
import numpy as np
import pytest
import scipy.sparse as sp
from _states import random_state, small_problem

from skfem_sheet import Sheet, assembly
from skfem_sheet.solve import build_problem


@pytest.fixture(scope="module", params=[False, True], ids=["full", "half"])
def problem(request):
    return small_problem(request.param)


def test_pressure_block_has_explicit_zero_diagonal(problem):
    K = problem.tangent(random_state(problem))
    d = K.diagonal()
    npres = problem.n_vertices
    assert np.all(d[-npres:] == 0)
    # every diagonal entry is stored
    rows = np.repeat(np.arange(K.shape[0]), np.diff(K.indptr))
    assert np.count_nonzero(rows == K.indices) == K.shape[0]


def test_pattern_matches_a_dof_level_assembly(problem):
    """The block-level sparsity pattern and scatter give the same matrix as a
    plain COO assembly of the element matrices over the free dofs."""
    w = random_state(problem, seed=5)
    Ke = problem.element_matrices(w)
    n = problem.ndof
    rows = np.repeat(problem.edofs, 34, axis=1).ravel()
    cols = np.tile(problem.edofs, (1, 34)).ravel()
    full = sp.csr_matrix((Ke.ravel(), (rows, cols)), shape=(n, n))
    ref = full[problem.free][:, problem.free]
    K = problem.tangent(w)
    assert K.has_sorted_indices
    assert abs(K - ref).max() <= 1e-12 * abs(ref).max()
    # every structural entry of the reference is in the pattern
    pat = sp.csr_matrix((np.ones(K.nnz), K.indices, K.indptr), shape=K.shape)
    refpat = (abs(ref) > 0).astype(float)
    assert (refpat - refpat.multiply(pat)).nnz == 0


@pytest.mark.slow
def test_pattern_of_a_large_mesh():
    """More than 46341 blocks: the block-pair keys need 64-bit integers
    (skfem's element dofs are int32; this crashed at hmax 0.03 with 8 layers)."""
    p = build_problem(Sheet(length=1.8, curvature=5.0), 0.03, 8, 2, True)
    assert p.n_nodes + p.n_vertices > 46341
    K = p.tangent(np.zeros(p.ndof))
    assert K.shape == (p.n_free, p.n_free) and K.has_sorted_indices


def test_threaded_tangent_equals_serial(monkeypatch):
    """The element kernels run on chunks of elements in threads; the assembled
    tangent must be the serial one exactly (disjoint slices, same arithmetic)."""
    pb = build_problem(Sheet(length=1.0, curvature=2.5), 0.15, None, 2, half=True)
    rng = np.random.default_rng(3)
    w = np.zeros(pb.ndof)
    w[:pb.nu_dof] = 1e-3 * rng.standard_normal(pb.nu_dof)
    w[pb.nu_dof:] = 0.1 * rng.standard_normal(pb.ndof - pb.nu_dof)
    monkeypatch.setattr(assembly, "THREAD_MIN_ELEMENTS", 10**9)
    serial = pb.tangent(w).toarray()
    r_serial, j_serial = pb.residual(w, 0.7)
    monkeypatch.setattr(assembly, "THREAD_MIN_ELEMENTS", 1)
    monkeypatch.setattr(assembly, "threads", lambda: 3)
    assert len(assembly.element_chunks(len(pb.dx))) == 3
    assert np.array_equal(pb.tangent(w).toarray(), serial)
    r, j = pb.residual(w, 0.7)
    assert np.array_equal(r, r_serial) and j == j_serial
    # a NaN in the last chunk only is not hidden by the other chunks' Jmin
    last = assembly.element_chunks(len(pb.dx))[-1]
    others = np.unique(pb.element_nodes[: last.start])
    node = np.setdiff1d(pb.element_nodes[last], others)[0]
    w_bad = w.copy()
    w_bad[3 * node] = np.nan
    r, j = pb.residual(w_bad, 0.7)
    assert not j > 0 and np.isnan(r).all()



def test_problems_on_one_mesh_share_one_assembler_with_independent_results():
    """Problems on one mesh (and their with_length copies) share the pattern and
    the work buffers; every assembly returns fresh arrays, so a matrix from one
    problem is not overwritten by the next assembly of another."""
    p = small_problem(True)
    q = p.with_length(0.9)
    assert q.assembler is p.assembler and q.space is not p.space
    w = random_state(p, seed=6)
    Kp = p.tangent(w)
    Kp_data = Kp.data.copy()
    Kq = q.tangent(w)
    assert np.array_equal(Kp.data, Kp_data)          # untouched by q's assembly
    assert not np.array_equal(Kq.data, Kp_data)      # q is another length
    assert np.array_equal(Kq.indices, Kp.indices) and np.array_equal(Kq.indptr, Kp.indptr)
    rp, _ = p.residual(w, 1.0)
    rp_copy = rp.copy()
    q.residual(w, 1.0)
    assert np.array_equal(rp, rp_copy)


def test_concurrent_assemblies_on_a_shared_assembler_equal_serial_ones():
    from concurrent.futures import ThreadPoolExecutor

    p = small_problem(True)
    q = p.with_length(0.9)
    w = random_state(p, seed=7)
    ref = {id(x): (x.tangent(w).data.copy(), x.residual(w, 0.5)[0].copy()) for x in (p, q)}
    with ThreadPoolExecutor(4) as ex:
        futs = [(x, ex.submit(x.tangent, w), ex.submit(x.residual, w, 0.5))
                for x in (p, q) * 6]
        for x, ft, fr in futs:
            assert np.array_equal(ft.result().data, ref[id(x)][0])
            assert np.array_equal(fr.result()[0], ref[id(x)][1])


def test_element_threads_belong_to_the_assembler(monkeypatch):
    """No process-wide pool: an assembler's threads start at its first
    assembly split into chunks and end when the assembler is dropped."""
    import gc
    import threading
    import time

    def ours():
        return [t for t in threading.enumerate() if t.name.startswith("skfem_sheet")]

    monkeypatch.setattr(assembly, "THREAD_MIN_ELEMENTS", 1)
    monkeypatch.setattr(assembly, "threads", lambda: 2)
    before = len(ours())
    pb = build_problem(Sheet(length=0.8), 0.25, None, 2, half=True)
    K = pb.tangent(np.zeros(pb.ndof))
    assert len(ours()) > before
    assert pb.assembler.workspace.executor() is pb.assembler.workspace.executor()
    del pb, K
    for _ in range(100):
        gc.collect()
        if len(ours()) == before:
            break
        time.sleep(0.02)
    assert len(ours()) == before


def test_problem_pickles_and_assembles_the_same():
    import pickle

    p = small_problem(False)
    w = random_state(p, seed=8)
    K = p.tangent(w)
    p2 = pickle.loads(pickle.dumps(p))
    assert p2.assembler.workspace.blocks is None       # buffers are not pickled
    assert np.array_equal(p2.tangent(w).data, K.data)


def test_scatter_operator_sums_entries_into_slots():
    S = assembly.scatter_operator([2, 0, 2], [0, 3, 4], 3, 6)
    x = np.arange(6.0) + 1.0
    assert np.array_equal(S @ x, [4.0, 0.0, 1.0 + 5.0])
    with pytest.raises(ValueError, match="increasing"):
        assembly.scatter_operator([0, 1], [3, 1], 2, 4)


def test_add_product_adds_in_place():
    rng = np.random.default_rng(9)
    S = sp.random(7, 5, density=0.4, format="csr", random_state=1)
    X = rng.normal(size=(5, 3))
    Y = rng.normal(size=(7, 3))
    expected = Y + S @ X
    assembly.add_product(S, X, Y)
    np.testing.assert_allclose(Y, expected, rtol=1e-14, atol=1e-14)
    with pytest.raises(ValueError, match="contiguous"):
        assembly.add_product(S, np.asfortranarray(X), Y)
