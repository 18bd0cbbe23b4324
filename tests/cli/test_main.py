"""The entry point: a misspelt option gets the nearest one suggested, with the sub-command's usage
(issue 32, defect 9: `bywire sim --scenaro x` got none)."""

from __future__ import annotations

import pytest

from bywire.cli.main import main


@pytest.mark.parametrize(
    ("argv", "suggested"),
    [
        (["sim", "--scenaro", "x"], "--scenario"),
        (["sim", "--scenaro=x"], "--scenario"),
        (["monitor", "--onse"], "--once"),
        (["dbc", "show", "--dcb", "x.dbc"], "--dbc"),  # an option of the sub-command's own
    ],
)
def test_a_misspelt_option_suggests_the_nearest(
    argv: list[str], suggested: str | None, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exited:
        main(argv)
    assert exited.value.code == 2
    err = capsys.readouterr().err
    last = err.strip().splitlines()[-1]
    assert last.startswith(f"bywire {argv[0]}: error: unrecognized arguments: ")
    if suggested is not None:
        assert last.endswith(f"(did you mean {suggested}?)")
        assert f"usage: bywire {argv[0]}" in err


def test_an_option_nothing_is_close_to_gets_no_guess(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["sim", "--zzzzzzzz"])
    assert "did you mean" not in capsys.readouterr().err
