"""`bywire demo`: runs every codec on damaged traffic and fails loudly when one misbehaves."""

from __future__ import annotations

import pytest

from bywire.cli.main import main
from bywire.protocol import dac6574


@pytest.mark.parametrize("seed", [0, 7, 12345])
def test_demo_passes_every_check_whatever_the_read_sizes(
    seed: int, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["demo", "--seed", str(seed)]) == 0
    out = capsys.readouterr().out
    assert "4 of 4 checks passed" in out
    assert "every one of the 127 intact frames" in out
    assert "rejected (bad CRC)" in out
    assert "CAN_BTR 0x001c0005" in out


def test_demo_exits_non_zero_when_a_codec_breaks(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(dac6574, "decode_write", lambda data: (1, 0))
    assert main(["demo"]) == 1
    out = capsys.readouterr().out
    assert "3 of 4 checks passed" in out
    assert "FAILED" in out
