"""Reading other people's CAN logs: every candump text format, python-can's formats, logs cut
short (text and BLF) read up to the cut, and errors in the user's terms.

The recorded frames are cantools' solar-car log (tests/data/cantools/msxii_battery_vt.candump,
`candump can0` format); the timed formats are written from those frames here, 10 ms apart.
"""

from __future__ import annotations

import datetime
import importlib.util
from pathlib import Path

import cantools
import pytest
from cantools.database.can import Database

from bywire.canlog.read import decode_messages, read_can_log, read_log
from bywire.errors import ConfigError
from tests.canlog import tesla_drive

DATA = Path(__file__).resolve().parents[1] / "data"
MSXII_LOG = DATA / "cantools/msxii_battery_vt.candump"
MSXII_DBC = DATA / "cantools/msxii_system_can.dbc"
START_S = 1_608_379_485.485261  # 2020-12-19 12:04:45.485261 UTC
STEP_S = 0.01


def _msxii() -> Database:
    loaded = cantools.database.load_file(MSXII_DBC)
    assert isinstance(loaded, Database)
    return loaded


def _recorded() -> list[tuple[int, bytes]]:
    """(id, data) of each line of the shipped log, parsed here by hand."""
    frames = []
    for line in MSXII_LOG.read_text(encoding="utf-8").splitlines():
        _channel, frame_id, _dlc, *data = line.split()
        frames.append((int(frame_id, 16), bytes.fromhex("".join(data))))
    return frames


def _text_line(style: str, index: int, frame_id: int, data: bytes) -> str:
    """One frame as candump prints it with -ta, -tz, -td, -tA or -L (see candump.c)."""
    stamp = START_S + index * STEP_S
    body = f"  can0  {frame_id:03X}   [{len(data)}]  {' '.join(f'{b:02X}' for b in data)}"
    if style == "-ta":
        return f"({stamp:.6f}){body}"
    if style == "-tz":
        return f"({index * STEP_S:010.6f}){body}"
    if style == "-td":
        return f"({(STEP_S if index else 0.0):010.6f}){body}"
    if style == "-tA":
        moment = datetime.datetime.fromtimestamp(stamp, datetime.UTC)
        return f"({moment:%Y-%m-%d %H:%M:%S.%f}){body}"
    assert style == "-L"
    return f"({stamp:.6f}) can0 {frame_id:03X}#{data.hex().upper()}"


def _write(tmp_path: Path, style: str, suffix: str = ".log") -> Path:
    lines = [_text_line(style, i, *frame) for i, frame in enumerate(_recorded())]
    path = tmp_path / f"msxii{style}{suffix}"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def test_the_shipped_log_without_timestamps_is_read_frame_by_frame() -> None:
    read = read_log(MSXII_LOG)
    assert [(m.arbitration_id, bytes(m.data)) for m in read.messages] == _recorded()
    assert len(read.messages) == 36
    assert (read.timed, read.stopped) == (False, None)
    assert [m.timestamp for m in read.messages] == [float(i) for i in range(36)]


@pytest.mark.parametrize("style", ["-ta", "-tz", "-td", "-tA", "-L"])
@pytest.mark.parametrize("suffix", [".log", ".txt"])
def test_every_candump_text_format_is_read(tmp_path: Path, style: str, suffix: str) -> None:
    read = read_log(_write(tmp_path, style, suffix))
    assert [(m.arbitration_id, bytes(m.data)) for m in read.messages] == _recorded()
    assert (read.timed, read.stopped) == (True, None)
    log = decode_messages(read.messages, _msxii())
    assert log.duration_s == pytest.approx(35 * STEP_S)
    # BATTERY_VT is multiplexed: module 6's voltage is in the 7th frame only
    assert log.signal("BATTERY_VT.MODULE_VOLTAGE_06").values == (39477,)
    assert log.signal("BATTERY_VT.MODULE_VOLTAGE_06").times_s == pytest.approx((6 * STEP_S,))


@pytest.mark.parametrize("style", ["-ta", "-L", "default"])
def test_a_log_cut_in_the_middle_of_a_line_is_read_up_to_the_cut(
    tmp_path: Path, style: str
) -> None:
    whole = MSXII_LOG if style == "default" else _write(tmp_path, style)
    text = whole.read_text(encoding="utf-8")
    cut = tmp_path / f"cut{style}.log"
    cut.write_text(text[: text.rfind("\n", 0, -1) + 12], encoding="utf-8")  # 11 chars of line 36
    read = read_log(cut)
    assert len(read.messages) == 35
    assert read.stopped == (
        "line 36 is cut short (the file ends without a newline): read the 35 lines before it"
    )


def test_a_line_cut_inside_its_data_stops_the_reading_there(tmp_path: Path) -> None:
    lines = _write(tmp_path, "-ta").read_text(encoding="utf-8").splitlines()
    lines[20] = lines[20][:-6]  # "[6]" announces six bytes; four remain
    broken = tmp_path / "broken.log"
    broken.write_text("\n".join(lines) + "\n", encoding="utf-8")
    read = read_log(broken)
    assert len(read.messages) == 20
    assert read.stopped is not None
    assert read.stopped.startswith("line 21 is not a candump frame (")


def test_error_frames_are_skipped_not_a_reason_to_stop(tmp_path: Path) -> None:
    lines = _write(tmp_path, "-tz").read_text(encoding="utf-8").splitlines()
    lines.insert(3, "(000.025000)  can0  20000004   [8]  00 00 00 00 00 00 00 00   ERRORFRAME")
    path = tmp_path / "errors.log"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    read = read_log(path)
    assert (len(read.messages), read.stopped) == (36, None)


@pytest.mark.parametrize("suffix", [".blf", ".asc", ".trc", ".csv", ".db", ".log"])
def test_python_can_formats_are_read_with_its_readers(tmp_path: Path, suffix: str) -> None:
    path = tesla_drive.write(tmp_path / f"drive{suffix}")
    read = read_log(path)
    expected = tesla_drive.frames()
    assert len(read.messages) == len(expected)
    assert [bytes(m.data) for m in read.messages[:50]] == [bytes(m.data) for m in expected[:50]]
    log = decode_messages(read.messages, tesla_drive.database())
    speed = log.signal("DI_speed.DI_vehicleSpeed")
    assert speed.values[-1] == pytest.approx(tesla_drive.speed_kph(3.98), abs=0.1)
    assert speed.times_s[-1] == pytest.approx(3.98, abs=1e-3)


@pytest.mark.skipif(
    importlib.util.find_spec("asammdf") is not None, reason="asammdf is installed: .mf4 reads"
)
def test_mf4_without_asammdf_names_the_package(tmp_path: Path) -> None:
    path = tmp_path / "drive.mf4"
    path.write_bytes(b"MDF     4.10    ")
    with pytest.raises(ConfigError, match=r"\.mf4 needs the asammdf package: pip install asammdf"):
        read_log(path)


@pytest.fixture(scope="module")
def drive_blf(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tesla_drive.write(tmp_path_factory.mktemp("blf") / "drive.blf")


@pytest.mark.parametrize("fraction", [0.3, 0.6, 0.95])
def test_a_truncated_blf_gives_the_frames_it_holds(
    drive_blf: Path, tmp_path: Path, fraction: float
) -> None:
    data = drive_blf.read_bytes()
    cut = tmp_path / "cut.blf"
    cut.write_bytes(data[: int(len(data) * fraction)])
    read = read_log(cut)
    whole = read_log(drive_blf).messages
    assert 0 < len(read.messages) < len(whole)
    assert [bytes(m.data) for m in read.messages] == [bytes(m.data) for m in whole][
        : len(read.messages)
    ]
    assert read.stopped == (
        f"the file is cut short ({len(data[: int(len(data) * fraction)])} of the {len(data)}"
        " bytes its header announces)"
    )


@pytest.mark.parametrize("size", [0, 10, 100, 143])
def test_a_blf_cut_inside_its_header_is_refused_in_plain_words(
    drive_blf: Path, tmp_path: Path, size: int
) -> None:
    cut = tmp_path / "head.blf"
    cut.write_bytes(drive_blf.read_bytes()[:size])
    with pytest.raises(ConfigError) as raised:
        read_can_log(cut, tesla_drive.database())
    message = str(raised.value)
    assert "head.blf" in message
    for internal in ("unpack", "buffer", "struct", "Error", "Traceback"):
        assert internal not in message


def test_a_damaged_csv_stops_at_the_damage_in_plain_words(tmp_path: Path) -> None:
    path = tesla_drive.write(tmp_path / "drive.csv")
    lines = path.read_text(encoding="utf-8").splitlines()
    lines[101] = "1700000001.0,not,a,frame"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    read = read_log(path)
    assert len(read.messages) == 100
    assert read.stopped == "stopped after frame 100: an entry that is not .csv CAN log data"


def test_relative_times_that_grow_are_read_as_candump_tz_not_td(tmp_path: Path) -> None:
    lines = _write(tmp_path, "-tz").read_text(encoding="utf-8").splitlines()
    lines[5] = lines[5].replace("(000.050000)", "(000.040000)")  # two frames in one instant
    path = tmp_path / "tz.log"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    times = [m.timestamp for m in read_log(path).messages]
    assert times[-1] == pytest.approx(0.35)
    assert times[4:6] == pytest.approx([0.04, 0.04])


def test_a_log_of_other_messages_has_nothing_to_plot(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="nothing to plot: 36 frames, none of them a message"):
        read_can_log(_write(tmp_path, "-ta"), tesla_drive.database())
