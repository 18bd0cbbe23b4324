"""The CAN log: python-can's writers by suffix, wall-clock timestamps, Tx/Rx, closed on error."""

from __future__ import annotations

import importlib.util
import itertools
from pathlib import Path

import can
import pytest

from bywire.canlog.write import BusTally, CanLog, check_log_path
from bywire.errors import ConfigError
from bywire.hal.simulated.can_bus import LoggedFrame

WALL_START_S = 1_750_000_000.0  # June 2025: what the log's reader should show as the date
FRAMES = [
    LoggedFrame(10.0005, 0x101, bytes(range(8)), "hlc"),
    LoggedFrame(10.0010, 0x200, b"\x12\x34", "bywire"),
    LoggedFrame(10.0200, 0x205, bytes(8), "bywire"),
]


NO_ASAMMDF = importlib.util.find_spec("asammdf") is None
MF4 = pytest.param(
    ".mf4",
    marks=pytest.mark.skipif(
        NO_ASAMMDF, reason="MF4 needs asammdf: pip install 'bywire[mf4]' to run this case"
    ),
)


@pytest.mark.parametrize("suffix", [".blf", ".asc", ".log", ".trc", ".csv", MF4])
def test_frames_read_back_in_order_with_ids_data_and_direction(suffix: str, tmp_path: Path) -> None:
    """Issue 32: python-can's TRC, CSV and MF4 (asammdf) writers too, read back by its readers.
    asammdf stays out of the test environment (it would load into every process that imports
    python-can): the MF4 case runs where it is installed."""
    path = tmp_path / f"run{suffix}"
    with CanLog(path, start_s=10.0, wall_start_s=WALL_START_S) as log:
        for frame in FRAMES:
            log(frame)
    assert log.frames == 3
    messages = list(can.LogReader(path))
    assert [m.arbitration_id for m in messages] == [0x101, 0x200, 0x205]
    assert [bytes(m.data) for m in messages] == [frame.data for frame in FRAMES]
    if suffix != ".csv":  # python-can's CSV has no direction column
        assert [m.is_rx for m in messages] == [True, False, False]
    assert not any(m.is_extended_id for m in messages)
    gaps_s = [
        later.timestamp - earlier.timestamp for earlier, later in itertools.pairwise(messages)
    ]
    assert gaps_s == pytest.approx([0.0005, 0.019], abs=2e-6)


@pytest.mark.parametrize("suffix", [".blf", ".log", ".trc", ".csv", MF4])
def test_timestamps_are_virtual_time_offset_to_the_wall_clock_start(
    suffix: str, tmp_path: Path
) -> None:
    path = tmp_path / f"run{suffix}"
    with CanLog(path, start_s=10.0, wall_start_s=WALL_START_S) as log:
        log(FRAMES[0])
    (message,) = can.LogReader(path)
    assert message.timestamp == pytest.approx(WALL_START_S + 0.0005, abs=1e-5)


def test_the_file_is_complete_even_when_the_run_raises(tmp_path: Path) -> None:
    path = tmp_path / "run.blf"

    def broken_run() -> None:
        with CanLog(path, start_s=10.0) as log:
            log(FRAMES[0])
            log(FRAMES[1])
            raise RuntimeError("the run broke")

    with pytest.raises(RuntimeError, match="broke"):
        broken_run()
    assert len(list(can.LogReader(path))) == 2  # BLF writes its header and count on close


@pytest.mark.parametrize("name", ["run.db", "run.txt", "run"])
def test_other_formats_are_refused_naming_the_allowed_ones(name: str, tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"\.blf, \.asc, \.log"):
        check_log_path(tmp_path / name)
    assert not (tmp_path / name).exists()


def test_a_missing_folder_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="does not exist"):
        CanLog(tmp_path / "missing" / "run.asc", start_s=0.0)


def test_the_tally_counts_frames_by_sender() -> None:
    tally = BusTally()
    for frame in FRAMES:
        tally(frame)
    assert tally.frames_by_sender == {"hlc": 1, "bywire": 2}


@pytest.mark.skipif(not NO_ASAMMDF, reason="asammdf is installed here")
def test_mf4_without_asammdf_is_refused_with_the_install_line(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"pip install 'bywire\[mf4\]'"):
        check_log_path(tmp_path / "run.mf4")
