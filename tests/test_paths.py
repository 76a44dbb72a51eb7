"""Paths through parameter space (skfem_sheet.paths): jumps at folds, none round the cusp."""
import numpy as np
import pytest

from skfem_sheet import Sheet, solve
from skfem_sheet.params import ParameterError
from skfem_sheet.paths import follow

COARSE = 0.2  # bistable at a/R = 2.5: L1*(1) 1.368, L0*(1) 1.225, cusp (b/a)* 0.631 at L 1.253


@pytest.mark.parametrize("through, match", [
    ([], "through"), ("1.3,1,2.5", "through"), ([(1.3, 1.0)], r"through\[0\]"),
    ([(1.3, 1.5, 2.5)], "tip width"), ([(1.3, 1.0, 7.0)], "curvature"),
])
def test_bad_input_raises_parameter_error(through, match):
    with pytest.raises(ParameterError, match=match):
        follow(Sheet(length=1.2), through, hmax=COARSE)


def test_bad_options_raise_parameter_error():
    with pytest.raises(ParameterError, match="start_path"):
        follow(Sheet(length=1.2), [(1.3, 1.0, 2.5)], start_path="sideways")
    with pytest.raises(ParameterError, match="sheet"):
        follow({"length": 1.2}, [(1.3, 1.0, 2.5)])


@pytest.mark.slow
def test_direct_path_jumps_at_the_standout_fold_and_round_the_cusp_does_not():
    """Grow an aloft rectangle through L1*: it falls, at the fold, by a
    large d.  Narrow it below (b/a)* first, grow it, widen it back: it ends
    drooped at the same (L, b, a/R) -- on the same branch as the fallen one --
    with no jump on the way."""
    start = Sheet(length=1.2, tip_width=1.0, curvature=2.5)
    direct = follow(start, [(1.45, 1.0, 2.5)], hmax=COARSE)
    assert direct.jumped and len(direct.jumps) == 1
    j = direct.jumps[0]
    assert j["fold"] and j["at"][0] == pytest.approx(1.368, abs=0.01)  # L1*(1) at hmax 0.2
    assert j["jump"] > 0.3  # the aloft sheet falls
    # the continuation is continuous everywhere else: small steps in d
    d = np.array([p["deflection"] for p in direct.points])
    assert np.sum(np.abs(np.diff(d)) > 0.2) == 1
    around = follow(start, [(1.2, 0.5, 2.5), (1.45, 0.5, 2.5), (1.45, 1.0, 2.5)], hmax=COARSE)
    assert not around.jumped
    assert around.points[-1]["length"] == pytest.approx(1.45)
    assert around.points[-1]["tip_width"] == pytest.approx(1.0)
    assert around.start_deflection == pytest.approx(direct.start_deflection, abs=1e-9)
    # both end drooped, on the branch a gravity-first solve finds there; at this
    # coarse mesh d depends on the mesh's stretch by some 0.1 (direct: the mesh
    # of L 1.2 stretched to 1.45; around: remeshed in the middle of its pieces)
    fresh = solve(Sheet(length=1.45, tip_width=1.0, curvature=2.5), path="gravity-first",
                  hmax=COARSE)
    assert around.end_deflection == pytest.approx(fresh.deflection, abs=0.03)
    assert direct.end_deflection == pytest.approx(fresh.deflection, abs=0.12)
    assert min(around.end_deflection, direct.end_deflection) - around.start_deflection > 0.5
