"""The build chain (skfem_sheet.build): what a solve or a study keeps, and its bound."""
import pickle
import re
from pathlib import Path

import numpy as np
import pytest

from skfem_sheet import Sheet, solve
from skfem_sheet.build import BuildChain
from skfem_sheet.params import ParameterError
from skfem_sheet.solve import build_problem

PACKAGE = Path(__file__).resolve().parent.parent / "skfem_sheet"


def test_a_chain_keeps_mesh_space_and_assembler_and_makes_problems():
    chain = BuildChain()
    a = chain.problem(Sheet(length=0.6, curvature=1.0), 0.2, half=True)
    b = chain.problem(Sheet(length=0.6, curvature=2.0, modulus=500.0), 0.2, half=True)
    assert a is not b and a.sheet.curvature == 1.0 and b.sheet.modulus == 500.0
    assert a.sheet_mesh is b.sheet_mesh and a.space is b.space and a.assembler is b.assembler
    assert len(chain) == 1
    # another quadrature order: another space and assembler on the same mesh
    c = chain.problem(Sheet(length=0.6), 0.2, quadrature_order=4, half=True)
    assert c.sheet_mesh is a.sheet_mesh and c.space is not a.space
    assert c.assembler is not a.assembler and len(chain) == 1
    # a stretched space has its reference's assembler
    assert chain.assembler(a.space.stretched(0.7)) is a.assembler


def test_the_chain_is_bounded_and_drops_the_least_recently_used_mesh():
    chain = BuildChain(max_meshes=2)
    m = [chain.mesh(Sheet(length=L), 0.25, half=True) for L in (0.5, 0.6)]
    assert chain.mesh(Sheet(length=0.5), 0.25, half=True) is m[0]  # 0.5 used last
    chain.mesh(Sheet(length=0.7), 0.25, half=True)  # drops 0.6
    assert len(chain) == 2
    assert chain.mesh(Sheet(length=0.5), 0.25, half=True) is m[0]
    again = chain.mesh(Sheet(length=0.6), 0.25, half=True)
    assert again is not m[1]
    np.testing.assert_array_equal(again.mesh.p, m[1].mesh.p)  # the same mesh, made again
    chain.clear()
    assert len(chain) == 0


def test_a_chain_of_no_meshes_keeps_nothing():
    chain = BuildChain(max_meshes=0)
    a = chain.problem(Sheet(length=0.5), 0.25, half=True)
    b = chain.problem(Sheet(length=0.5), 0.25, half=True)
    assert len(chain) == 0 and a.sheet_mesh is not b.sheet_mesh and a.assembler is not b.assembler


@pytest.mark.parametrize("bad", [-1, 1.5, "2", True])
def test_bad_bound_raises_parameter_error(bad):
    with pytest.raises(ParameterError, match="max_meshes"):
        BuildChain(max_meshes=bad)


def test_a_chain_pickles_empty():
    chain = BuildChain(max_meshes=3)
    chain.mesh(Sheet(length=0.5), 0.25)
    copy = pickle.loads(pickle.dumps(chain))
    assert copy.max_meshes == 3 and len(copy) == 0 and len(chain) == 1


def test_build_problem_without_a_chain_builds_afresh():
    a = build_problem(Sheet(length=0.5), 0.25, None, 2, half=True)
    b = build_problem(Sheet(length=0.5), 0.25, None, 2, half=True)
    assert a.assembler is not b.assembler
    np.testing.assert_array_equal(a.sheet_mesh.mesh.p, b.sheet_mesh.mesh.p)


def test_solve_with_a_chain_reuses_its_meshes_and_gives_the_same_numbers():
    """A study's chain: the second solve of a sheet on the same meshes (the
    other path) builds nothing, and every number is the one of a solve
    with a chain of its own."""
    sheet = Sheet(length=0.6, curvature=2.0)
    chain = BuildChain()
    r1 = solve(sheet, hmax=0.1, coarse_hmax=0.2, chain=chain)
    assert len(chain) == 2  # the coarse start's mesh and the solve's own
    r2 = solve(sheet, path="gravity-first", hmax=0.1, coarse_hmax=0.2, chain=chain)
    assert len(chain) == 2 and r2.problem.assembler is r1.problem.assembler
    alone = solve(sheet, path="gravity-first", hmax=0.1, coarse_hmax=0.2)
    assert alone.problem.assembler is not r2.problem.assembler
    assert alone.deflection == r2.deflection and np.array_equal(alone.w, r2.w)
    assert alone.newton_iterations == r2.newton_iterations
    with pytest.raises(ParameterError, match="chain"):
        solve(sheet, hmax=0.1, chain={"max_meshes": 2})


def test_nothing_is_cached_at_module_level():
    """The build chain is the only keeper of meshes, spaces and assemblers:
    no functools cache and no process-wide pool in the package."""
    found = [f"{p.relative_to(PACKAGE)}:{i}" for p in PACKAGE.rglob("*.py")
             for i, line in enumerate(p.read_text().splitlines(), 1)
             if re.search(r"\b(lru_cache|functools\.cache|@cache\b|_POOL)", line)]
    assert not found, found
