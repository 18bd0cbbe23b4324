"""`bywire dbc show` and `bywire dbc codegen` through the real entry point."""

from __future__ import annotations

from pathlib import Path

import cantools
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
            unit = signal.unit or "-"  # `dbc show` prints - for a signal with no unit
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
    names = ["robot.h", "robot.c", "robot_protection.h", "robot_protection.c"]
    names += ["robot_secoc.h", "robot_secoc.c"]
    assert written == [str(outdir / name) for name in names]
    assert "uint8_t robot_command_crc(" in (outdir / "robot_protection.h").read_text("utf-8")
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


OVERFLOWING_DBC = """VERSION ""
BU_: HLC
BO_ 292 Tiny: 1 HLC
 SG_ level : 4|8@1+ (1,0) [0|255] "" Vector__XXX
"""


@pytest.mark.parametrize(
    ("content", "problem"),
    [
        (
            OVERFLOWING_DBC,
            "The signal level does not fit in message Tiny",
        ),  # C would write dst_p[1]
        ((Path(__file__).parents[1] / "data/opendbc/vw_mqb.dbc").read_text("utf-8"), "overlap"),
    ],
)
def test_codegen_refuses_a_dbc_that_fails_the_strict_checks(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], content: str, problem: str
) -> None:
    """Issue 32, defect 3: a note and exit 0, and C that overflowed a 1-byte frame's buffer."""
    path = tmp_path / "lenient.dbc"
    path.write_text(content, encoding="utf-8")
    assert main(["dbc", "codegen", str(tmp_path / "out"), "--dbc", str(path)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert len(captured.err.splitlines()) == 1
    assert problem in captured.err
    assert "passes cantools' strict checks" in captured.err
    assert not (tmp_path / "out").exists()
    assert main(["dbc", "show", "--dbc", str(path)]) == 0  # reading it stays lenient


# --- other people's databases: cantools' and opendbc's files in tests/data ---------------------

DATA = Path(__file__).resolve().parents[1] / "data"


def _show(capsys: pytest.CaptureFixture[str], path: Path) -> tuple[list[str], str]:
    assert main(["dbc", "show", "--dbc", str(path)]) == 0
    captured = capsys.readouterr()
    return captured.out.splitlines(), captured.err


def _mux_paths(lines: list[str], message: str) -> dict[str, set[tuple[tuple[str, int], ...]]]:
    """Each signal of one message with the `when MUX = value` conditions it is listed under."""
    start = next(i for i, line in enumerate(lines) if line.split()[1:2] == [message])
    paths: dict[str, set[tuple[tuple[str, int], ...]]] = {}
    stack: list[tuple[int, tuple[str, int]]] = []  # (indent of the when line, condition)
    for line in lines[start + 3 :]:
        if not line:
            break
        indent = len(line) - len(line.lstrip())
        while stack and stack[-1][0] >= indent:
            stack.pop()
        words = line.split()
        if words[0] == "when":
            stack.append((indent, (words[1], int(words[3].rstrip(":")))))
        else:
            paths.setdefault(words[0], set()).add(tuple(condition for _, condition in stack))
    return paths


def test_cantools_multiplex_dbc_is_shown_per_mux_value(capsys: pytest.CaptureFixture[str]) -> None:
    lines, err = _show(capsys, DATA / "cantools/multiplex.dbc")
    assert err == ""
    paths = _mux_paths(lines, "Message1")
    assert paths["Multiplexor"] == {()}
    # SG_MUL_VAL_ puts these four under 8, 16 and 24; their own SG_ line says only m8
    for name in ("BIT_J", "BIT_C", "BIT_G", "BIT_L"):
        assert paths[name] == {(("Multiplexor", value),) for value in (8, 16, 24)}
    for name in ("BIT_A", "BIT_B", "BIT_D", "BIT_E", "BIT_F", "BIT_H", "BIT_K"):
        assert paths[name] == {(("Multiplexor", 24),)}
    multiplexor = next(line for line in lines if line.split()[:1] == ["Multiplexor"])
    assert multiplexor.split()[1:3] == ["2", "6"]
    assert multiplexor.endswith("(multiplexer)")


def test_cantools_extended_multiplexing_is_shown_as_a_tree(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # SG_MUL_VAL_ of multiplex_2.dbc: S1 under S0 = 0; S2, S3 under S1 = 0; S4 under S1 = 2 ...
    lines, _err = _show(capsys, DATA / "cantools/multiplex_2.dbc")
    paths = _mux_paths(lines, "Extended")
    assert paths["S2"] == paths["S3"] == {(("S0", 0), ("S1", 0))}
    assert paths["S4"] == {(("S0", 0), ("S1", 2))}
    assert paths["S5"] == {(("S0", 1),)}
    assert (paths["S7"], paths["S8"]) == ({(("S6", 1),)}, {(("S6", 2),)})
    # One signal under several values (S1 m1, m3 of S0 in "Shared") is listed under each.
    assert _mux_paths(lines, "Shared")["S1"] == {(("S0", 1),), (("S0", 3),)}


def test_a_real_car_multiplexer_shows_its_value_names(capsys: pytest.CaptureFixture[str]) -> None:
    lines, _err = _show(capsys, DATA / "opendbc/tesla_model3_party.dbc")
    assert "    when VCFRONT_LVPowerStateIndex = 1 (Mux1):" in lines
    paths = _mux_paths(lines, "VCFRONT_LVPowerState")
    assert paths["VCFRONT_epasLVState"] == {(("VCFRONT_LVPowerStateIndex", 1),)}
    assert paths["VCFRONT_parkLVState"] == {(("VCFRONT_LVPowerStateIndex", 0),)}
    assert paths["VCFRONT_vehiclePowerState"] == {()}


def test_signals_of_one_mux_value_never_share_bits(capsys: pytest.CaptureFixture[str]) -> None:
    lines, _err = _show(capsys, DATA / "opendbc/tesla_model3_party.dbc")
    paths = _mux_paths(lines, "VCFRONT_LVPowerState")
    rows = {
        line.split()[0]: line.split() for line in lines if line.split()[:1] not in ([], ["when"])
    }
    for value in (0, 1):
        listed = [
            name
            for name, conditions in paths.items()
            if () in conditions or (("VCFRONT_LVPowerStateIndex", value),) in conditions
        ]
        bits = [bit for name in listed for bit in _bits(int(rows[name][1]), int(rows[name][2]))]
        assert len(bits) == len(set(bits)), value


def _bits(start: int, length: int) -> range:
    return range(start, start + length)  # little-endian signals: consecutive bits


def test_a_dbc_that_fails_the_strict_checks_is_shown_with_a_note(
    capsys: pytest.CaptureFixture[str],
) -> None:
    lines, err = _show(capsys, DATA / "opendbc/vw_mqb.dbc")
    assert err.startswith("bywire dbc: note: vw_mqb.dbc fails cantools' strict checks (")
    assert "overlapping" in err
    assert any(line.startswith("0x6B4  VIN_01  ") for line in lines)
    assert "    when VIN_01_MUX = 2:" in lines


def test_path_names_the_packaged_dbc_and_export_copies_it_byte_for_byte(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 32: tools that need the file (cantools, SavvyCAN, Foxglove) when bywire is
    installed non-editable get its path, or a copy."""
    assert main(["dbc", "path"]) == 0
    path = Path(capsys.readouterr().out.strip())
    assert path.name == "albert.dbc"
    loaded = cantools.database.load_file(path)
    assert isinstance(loaded, cantools.database.can.Database)
    assert loaded.get_message_by_name("MovementCommand").frame_id == 0x101
    copy = tmp_path / "robot.dbc"
    assert main(["dbc", "export", str(copy)]) == 0
    assert copy.read_bytes() == path.read_bytes()
    capsys.readouterr()
    copy.write_text("mine", encoding="utf-8")
    assert main(["dbc", "export", str(copy)]) == 2
    assert "exists: add --force" in capsys.readouterr().err
    assert copy.read_text(encoding="utf-8") == "mine"
    assert main(["dbc", "export", str(copy), "--force"]) == 0
    assert copy.read_bytes() == path.read_bytes()
