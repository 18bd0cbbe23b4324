"""`bywire dbc show` and `bywire dbc codegen` through the real entry point."""

from __future__ import annotations

from pathlib import Path

import pytest

from bywire.cli.main import main
from bywire.protocol.dbc import database

SMALL_DBC = """VERSION ""
BU_: HLC
BO_ 291 Probe: 2 HLC
 SG_ speed_kph : 0|16@1- (0.1,0) [-100|100] "km/h" Vector__XXX
CM_ BO_ 291 "A one-message database.";
BA_DEF_ BO_ "GenMsgCycleTime" INT 0 65535;
BA_ "GenMsgCycleTime" BO_ 291 100;
"""


def test_show_lists_every_message_with_id_and_signals_with_units(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["dbc", "show"]) == 0
    lines = capsys.readouterr().out.splitlines()
    for message in database().messages:
        head = next(line for line in lines if line.startswith(f"0x{message.frame_id:03X}  "))
        assert message.name in head
        assert f"DLC {message.length}" in head
        assert "period 20 ms" in head
        for signal in message.signals:
            unit = str(signal.unit)
            assert any(line.split()[:1] == [signal.name] and unit in line for line in lines)


def test_show_gives_start_bit_length_and_value_tables(capsys: pytest.CaptureFixture[str]) -> None:
    main(["dbc", "show"])
    lines = capsys.readouterr().out.splitlines()
    gear = next(line for line in lines if line.split()[:1] == ["gear"])
    assert gear.split()[1:4] == ["52", "2", "unsigned"]
    assert gear.endswith("0=NEUTRAL 1=FORWARD 2=REVERSE")
    speed = next(line for line in lines if line.split()[:1] == ["left_mps"])
    assert "signed" in speed
    assert "0.01" in speed
    assert "[-327.68|327.67]" in speed


def test_show_reads_another_dbc_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "small.dbc"
    path.write_text(SMALL_DBC, encoding="utf-8")
    assert main(["dbc", "show", "--dbc", str(path)]) == 0
    out = capsys.readouterr().out
    assert "0x123  Probe  sender HLC  DLC 2  period 100 ms" in out
    assert "A one-message database." in out
    assert "km/h" in out
    assert "MovementCommand" not in out


def test_codegen_writes_header_and_source(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    outdir = tmp_path / "new" / "dir"
    assert main(["dbc", "codegen", str(outdir), "--name", "robot"]) == 0
    written = capsys.readouterr().out.split()
    assert written == [str(outdir / "robot.h"), str(outdir / "robot.c")]
    assert "ROBOT_MOVEMENT_COMMAND_FRAME_ID" in (outdir / "robot.h").read_text(encoding="utf-8")
    assert '#include "robot.h"' in (outdir / "robot.c").read_text(encoding="utf-8")


@pytest.mark.parametrize("content", [None, "this is not a DBC file\n", b"\x81\x8d\x90\xff"])
@pytest.mark.parametrize("action", [["show"], ["codegen", "OUT"]])
def test_unreadable_dbc_exits_2_with_one_line(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    content: str | bytes | None,
    action: list[str],
) -> None:
    path = tmp_path / "bad.dbc"
    if isinstance(content, str):
        path.write_text(content, encoding="utf-8")
    elif isinstance(content, bytes):
        path.write_bytes(content)
    argv = ["dbc", *(str(tmp_path / arg) if arg == "OUT" else arg for arg in action)]
    assert main([*argv, "--dbc", str(path)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert len(captured.err.splitlines()) == 1
    assert "bad.dbc" in captured.err
    assert not (tmp_path / "OUT").exists()


def test_codegen_into_a_file_exits_2_with_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("", encoding="utf-8")
    assert main(["dbc", "codegen", str(blocker)]) == 2
    assert len(capsys.readouterr().err.splitlines()) == 1
