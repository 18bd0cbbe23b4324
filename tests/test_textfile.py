"""Reading a small text file a user named: what is not one is refused in one line, at once."""

from __future__ import annotations

import os
import threading
from pathlib import Path

import pytest

from bywire.errors import ConfigError
from bywire.textfile import check_regular, read_text
from tests.toml_mutations import assert_refused_in_one_line, run_bywire

LIMIT_S = 10.0  # a FIFO must be refused at once; this is only how long the test waits for that


def _fifo(tmp_path: Path) -> Path:
    path = tmp_path / "robot.toml"
    os.mkfifo(path)
    return path


def test_a_regular_file_is_read_whole(tmp_path: Path) -> None:
    path = tmp_path / "robot.toml"
    path.write_text("name = 'é'\n", encoding="utf-8")
    assert read_text(path, "configuration file") == "name = 'é'\n"


@pytest.mark.parametrize(
    ("make", "says"),
    [
        (lambda tmp: Path("/dev/zero"), "configuration file is a character device, not a regular"),
        (lambda tmp: tmp, "configuration file is a directory, not a regular"),
        (lambda tmp: tmp / "missing.toml", "no such configuration file"),
    ],
    ids=["dev-zero", "directory", "missing"],
)
def test_what_is_not_a_file_is_refused(tmp_path: Path, make: object, says: str) -> None:
    path = make(tmp_path)  # type: ignore[operator]
    with pytest.raises(ConfigError, match=f"^{path}: {says}"):
        read_text(path, "configuration file")


def test_a_fifo_is_refused_without_waiting_for_a_writer(tmp_path: Path) -> None:
    path = _fifo(tmp_path)
    outcome: list[str] = []

    def read() -> None:
        try:
            read_text(path, "file")
        except ConfigError as error:
            outcome.append(str(error))

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    reader.join(LIMIT_S)
    assert not reader.is_alive(), "read_text waited on the FIFO"
    assert outcome == [f"{path}: file is a FIFO (named pipe), not a regular file"]
    with pytest.raises(ConfigError, match="FIFO"):
        check_regular(path, "run record")


def test_a_file_over_the_limit_and_one_not_utf8_are_refused(tmp_path: Path) -> None:
    big, latin = tmp_path / "big.toml", tmp_path / "latin.toml"
    big.write_bytes(b"#" * 2049)
    latin.write_bytes(b"name = '\xe9'\n")
    with pytest.raises(ConfigError, match="larger than 2 KiB: refused"):
        read_text(big, "scenario file", limit_bytes=2048)
    with pytest.raises(ConfigError, match=r"latin.toml: not UTF-8 text \(byte 8\)"):
        read_text(latin, "scenario file")


@pytest.mark.parametrize("command", [["config", "check"], ["sim", "--scenario"]])
def test_the_commands_refuse_dev_zero_and_a_fifo_in_one_line(
    tmp_path: Path, command: list[str]
) -> None:
    for path in (Path("/dev/zero"), _fifo(tmp_path)):
        status, err = run_bywire(*command, str(path))
        assert_refused_in_one_line(command[0], status, err)
        assert "not a regular file" in err
