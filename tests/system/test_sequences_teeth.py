"""The sequence check has teeth: each old behaviour of issue 10, put back by monkeypatch, is found
by `test_sequences.check_sequences` within its default budget (without shrinking, to stay fast:
the failing example itself is what matters here).

Row 3 (a refused arming remembered) needs a longer search than this budget's draws give; `bywire
verify` finds it (`tests/cli/test_verify.py`), as it finds rows 4, 6, 7 and 8
(`tests/sim/test_verify.py`)."""

from __future__ import annotations

import pytest

from tests.system.old_bugs import OLD_BUGS
from tests.system.test_sequences import check_sequences

FOUND_HERE = [name for name in OLD_BUGS if name != "row_3_a_refused_arming_is_remembered"]


def found() -> bool:
    try:
        check_sequences(shrink=False)
    except AssertionError:
        return True
    return False


@pytest.mark.parametrize("bug", FOUND_HERE)
def test_an_old_bug_put_back_is_found(bug: str, monkeypatch: pytest.MonkeyPatch) -> None:
    OLD_BUGS[bug](monkeypatch)
    assert found()
