"""`bywire bittiming`: the printed table holds Figure 20, ip-link lines, units, one-line errors."""

from __future__ import annotations

import json
import re
import subprocess
import sys

import pytest

from bywire.cli import bittiming as cli
from bywire.cli.main import main
from bywire.errors import ConfigError

# Figure 20 (48 MHz, 87.5 %): kbit/s, accuracy, prescaler, quanta, seg 1, seg 2, sample %, BTR.
FIGURE_20 = [
    ("1000", "0.0000", "3", "16", "13", "2", "87.5", "0x001c0002"),
    ("1000", "0.0000", "4", "12", "10", "1", "91.7", "0x00090003"),
    ("1000", "0.0000", "6", "8", "6", "1", "87.5", "0x00050005"),
    ("800", "0.0000", "4", "15", "12", "2", "86.7", "0x001b0003"),
    ("800", "0.0000", "5", "12", "10", "1", "91.7", "0x00090004"),
    ("800", "0.0000", "6", "10", "8", "1", "90.0", "0x00070005"),
    ("500", "0.0000", "6", "16", "13", "2", "87.5", "0x001c0005"),
    ("500", "0.0000", "8", "12", "10", "1", "91.7", "0x00090007"),
    ("500", "0.0000", "12", "8", "6", "1", "87.5", "0x0005000b"),
    ("250", "0.0000", "12", "16", "13", "2", "87.5", "0x001c000b"),
    ("250", "0.0000", "16", "12", "10", "1", "91.7", "0x0009000f"),
]
ROW = re.compile(
    r"(\*?)\s+(\S+)\s+(\S+)\s+(\d+)\s+(\d+)\s+(\d+)\s+(\d+)\s+(\S+)\s+(0x[0-9a-f]{8})\s.*"
)
IP_LINK_BITRATE = "ip link set can0 type can bitrate 500000 sample-point 0.875 sjw 1"
IP_LINK_TQ = "ip link set can0 type can tq 125 prop-seg 6 phase-seg1 7 phase-seg2 2 sjw 1"


def _run(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    status = main(["bittiming", *args])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def _rows(output: str) -> list[tuple[str, ...]]:
    return [match.groups() for line in output.splitlines() if (match := ROW.fullmatch(line))]


def test_table_contains_every_row_of_figure_20(capsys: pytest.CaptureFixture[str]) -> None:
    status, out, err = _run(capsys, "--clock", "48MHz", "--sample-point", "87.5")
    assert (status, err) == (0, "")
    rows = [row[1:] for row in _rows(out)]
    assert [row for row in rows if row in FIGURE_20] == FIGURE_20
    assert {row[0] for row in rows} == {"1000", "800", "500", "250", "125", "100", "50", "20", "10"}


def test_one_row_per_bitrate_is_marked(capsys: pytest.CaptureFixture[str]) -> None:
    _status, out, _err = _run(capsys, "--clock", "48MHz")
    marked = [(row[1], row[3]) for row in _rows(out) if row[0] == "*"]
    assert marked[:4] == [("1000", "3"), ("800", "4"), ("500", "6"), ("250", "12")]
    assert len(marked) == 9


def test_one_bitrate_prints_the_recommended_row_and_ip_link(
    capsys: pytest.CaptureFixture[str],
) -> None:
    status, out, _err = _run(capsys, "--clock", "48MHz", "--bitrate", "500k")
    assert status == 0
    assert ("*", "500", "0.0000", "6", "16", "13", "2", "87.5", "0x001c0005") in _rows(out)
    assert f"  {IP_LINK_BITRATE}" in out.splitlines()
    assert f"  {IP_LINK_TQ}" in out.splitlines()


def test_channel_option_names_the_interface(capsys: pytest.CaptureFixture[str]) -> None:
    _status, out, _err = _run(capsys, "--clock", "48M", "--bitrate", "500k", "--channel", "can1")
    assert IP_LINK_TQ.replace("can0", "can1") in out
    assert "can0" not in out


@pytest.mark.parametrize("clock", ["48MHz", "48M", "48000000", "48 MHz", "48mhz", "48000k", "48"])
@pytest.mark.parametrize("bitrate", ["500k", "500000", "0.5M", "500kbit/s"])
def test_accepted_clock_and_bitrate_forms(
    capsys: pytest.CaptureFixture[str], clock: str, bitrate: str
) -> None:
    _status, out, _err = _run(capsys, "--clock", clock, "--bitrate", bitrate)
    assert IP_LINK_TQ in out


@pytest.mark.parametrize(
    ("text", "value"),
    [("48", 48_000_000), ("8", 8_000_000), ("42.5", 42_500_000), ("999", 999_000_000),
     ("1000", 1000), ("16000000", 16_000_000), ("48Hz", 48), ("48 hz", 48), ("48k", 48_000)],
)  # fmt: skip
def test_a_bare_clock_below_1000_is_mhz(text: str, value: int) -> None:
    assert cli.parse_clock_hz(text) == value


def test_a_clock_that_reaches_no_bitrate_exits_1(capsys: pytest.CaptureFixture[str]) -> None:
    status, out, err = _run(capsys, "--clock", "48Hz")
    assert (status, err) == (1, "")
    assert _rows(out) == []
    assert "no exact setting for 1000000 bit/s with a 48 Hz clock (reachable: 1..6 bit/s)" in out


def test_sjw_2_is_in_both_ip_link_lines(capsys: pytest.CaptureFixture[str]) -> None:
    status, out, _err = _run(capsys, "--clock", "48", "--bitrate", "500k", "--sjw", "2")
    assert status == 0
    assert IP_LINK_BITRATE.replace("sjw 1", "sjw 2") in out.splitlines()[-2]
    assert IP_LINK_TQ.replace("sjw 1", "sjw 2") in out.splitlines()[-1]


def test_an_sjw_linux_would_refuse_with_bitrate_gets_only_the_tq_line(
    capsys: pytest.CaptureFixture[str],
) -> None:
    args = ("--clock", "48MHz", "--bitrate", "500k", "--sample-point", "60", "--sjw", "4")
    status, out, _err = _run(capsys, *args)
    assert status == 0
    assert "sample-point" not in out
    assert "phase-seg1 3 < sjw 4" in out
    assert out.splitlines()[-1] == (
        "  ip link set can0 type can tq 167 prop-seg 2 phase-seg1 4 phase-seg2 5 sjw 4"
    )


def test_nearest_names_an_exact_bitrate_at_another_sample_point(
    capsys: pytest.CaptureFixture[str],
) -> None:
    args = ("--clock", "25MHz", "--bitrate", "1M", "--sample-point", "50")
    status, out, _err = _run(capsys, *args)
    assert status == 1
    assert "at sample point 50 % +- 5 and SJW 1" in out
    assert "nearest: prescaler 1 x 25 tq = 1000000 bit/s (+0.0000 %) at sample point 68.0 %" in out


@pytest.mark.parametrize(
    ("text", "value"),
    [("1M", 1_000_000), ("125k", 125_000), ("10000", 10_000), ("1.5M", 1_500_000)],
)
def test_parse_bitrate(text: str, value: int) -> None:
    assert cli.parse_bitrate_bps(text) == value


@pytest.mark.parametrize(
    ("text", "value"),
    [("87.5", 0.875), ("87.5%", 0.875), ("0.875", 0.875), ("80", 0.8), ("1", 1.0)],
)
def test_parse_sample_point_percent_or_fraction(text: str, value: float) -> None:
    assert cli.parse_sample_point(text) == pytest.approx(value)


@pytest.mark.parametrize("text", ["48GHz", "fast", "48.5Hz", "-48M", "48Mbps", "", "48 M Hz x"])
def test_bad_clock_names_the_accepted_forms(text: str) -> None:
    with pytest.raises(ConfigError, match="48MHz, 48M"):
        cli.parse_clock_hz(text)


@pytest.mark.parametrize(
    "args",
    [
        ["--clock", "48GHz"],
        ["--clock", "fast"],
        ["--clock", "48M", "--bitrate", "500x"],
        ["--clock", "48M", "--bitrate", "7M"],
        ["--clock", "48M", "--sample-point", "abc"],
        ["--clock", "48M", "--sample-point", "99"],
        ["--clock", "48M", "--sjw", "0"],
        ["--clock", "48M", "--sjw", "two"],
        ["--clock", "0"],
    ],
)
def test_bad_arguments_exit_2_with_one_line(
    capsys: pytest.CaptureFixture[str], args: list[str]
) -> None:
    status, out, err = _run(capsys, *args)
    assert (status, out) == (2, "")
    assert len(err.splitlines()) == 1
    assert err.startswith("bywire bittiming: error: ")


def test_bitrate_without_exact_setting_suggests_the_nearest(
    capsys: pytest.CaptureFixture[str],
) -> None:
    status, out, _err = _run(capsys, "--clock", "45MHz", "--bitrate", "800k")
    assert status == 1
    assert _rows(out) == []
    assert "no exact setting for 800000 bit/s" in out
    assert "nearest: prescaler 7 x 8 tq = 803571 bit/s (+0.4464 %)" in out


def test_survey_skips_rates_a_slow_clock_cannot_reach(capsys: pytest.CaptureFixture[str]) -> None:
    status, out, _err = _run(capsys, "--clock", "1MHz")
    assert status == 0
    assert (
        "no exact setting for 1000000 bit/s with a 1000000 Hz clock (reachable: 40..125000" in out
    )
    assert ("*", "125", "0.0000", "1", "8", "6", "1", "87.5", "0x00050000") in _rows(out)


def test_json_output(capsys: pytest.CaptureFixture[str]) -> None:
    status, out, _err = _run(capsys, "--clock", "48MHz", "--json")
    document = json.loads(out)
    assert (status, document["clock_hz"], document["no_exact_setting_bps"]) == (0, 48_000_000, [])
    best = [row for row in document["rows"] if row["bitrate_bps"] == 500_000 and row["recommended"]]
    assert [(row["brp"], row["btr"]) for row in best] == [(6, "0x001c0005")]
    assert best[0]["ip_link"] == [IP_LINK_BITRATE, IP_LINK_TQ]


def test_help_explains_the_units(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["bittiming", "--help"])
    out = capsys.readouterr().out
    assert exit_info.value.code == 0
    assert "48MHz" in out
    assert "0.875" in out
    assert "500k" in out


def test_runs_as_a_module() -> None:
    command = [sys.executable, "-m", "bywire.cli.main", "bittiming", "--clock", "48MHz"]
    good = subprocess.run(
        [*command, "--bitrate", "500k"], capture_output=True, text=True, check=False
    )
    bad = subprocess.run([*command, "--sjw", "5"], capture_output=True, text=True, check=False)
    assert (good.returncode, good.stderr) == (0, "")
    assert IP_LINK_TQ in good.stdout
    assert bad.returncode == 2
    assert bad.stderr.strip() == "bywire bittiming: error: sjw must be 1..4 quanta (bxCAN), got 5"
