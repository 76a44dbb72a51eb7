"""fold_lengths closes its progress bars, also when a continuation raises."""
import pytest

from skfem_sheet import bistability
from skfem_sheet.bistability import lengths
from skfem_sheet.params import ParameterError


@pytest.mark.parametrize("fail_on", [1, 2])
def test_fold_lengths_closes_its_bars_when_a_continuation_raises(monkeypatch, fail_on):
    made, calls = [], []
    real_bars = lengths._bars

    def bars(progress, lo, hi):
        out = real_bars(progress, lo, hi)
        made.extend(out)
        return out

    def follow(name, sheet, stop, **kw):
        # fold_lengths' two continuations in L (bistability.lengths.follow_branch,
        # patched where fold_lengths looks it up)
        calls.append(stop)
        if len(calls) == fail_on:
            raise ParameterError("the starting sheet could not be solved")
        return bistability.Branch(())

    monkeypatch.setattr(lengths, "_bars", bars)
    monkeypatch.setattr(lengths, "follow_branch", follow)
    with pytest.raises(ParameterError, match="could not be solved"):
        bistability.fold_lengths(bistability.Sheet(length=1.0, curvature=2.5),
                                 lengths=(1.0, 1.7), hmax=0.2, progress=True)
    assert len(made) == 2 and len(calls) == fail_on
    # tqdm marks a closed bar disabled; an open one would linger on the terminal
    assert all(b.bar.disable for b in made)
