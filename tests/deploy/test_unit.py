"""The systemd unit: `systemd-analyze verify` accepts it, and its exposure, scored by systemd's own
`systemd-analyze security --offline=yes`, is at most 2.0 (with the telemetry drop-in too)."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
UNIT = ROOT / "deploy" / "bywire.service"
TELEMETRY = ROOT / "deploy" / "bywire-telemetry.conf"
ANALYZE = shutil.which("systemd-analyze")
MAX_EXPOSURE = 2.0

pytestmark = pytest.mark.skipif(ANALYZE is None, reason="systemd-analyze is not installed")


def _unit_here(tmp_path: Path, *drop_ins: Path) -> Path:
    """The unit with ExecStart on this machine's bywire (verify checks the program exists) and
    the drop-ins' lines appended, as systemd merges them."""
    program = Path(sys.executable).parent / "bywire"
    executable = program if program.exists() else Path("/bin/true")
    text = UNIT.read_text(encoding="utf-8").replace("/opt/bywire/.venv/bin/bywire", str(executable))
    service, install = text.split("[Install]")
    for drop_in in drop_ins:
        service += drop_in.read_text(encoding="utf-8").replace("[Service]\n", "") + "\n"
    text = service + "[Install]" + install
    unit = tmp_path / "bywire.service"
    unit.write_text(text, encoding="utf-8")
    return unit


def _exposure(unit: Path) -> float:
    result = subprocess.run(
        [str(ANALYZE), "security", "--offline=yes", str(unit)],
        capture_output=True,
        text=True,
        check=False,
    )
    match = re.search(r"Overall exposure level for bywire.service: (\d+\.\d)", result.stdout)
    assert match is not None, result.stdout + result.stderr
    return float(match.group(1))


def test_systemd_verifies_the_unit(tmp_path: Path) -> None:
    result = subprocess.run(
        [str(ANALYZE), "verify", str(_unit_here(tmp_path))],
        capture_output=True,
        text=True,
        check=False,
    )
    assert (result.returncode, result.stderr) == (0, "")


def test_the_unit_is_exposed_at_most_2_0(tmp_path: Path) -> None:
    assert _exposure(_unit_here(tmp_path)) <= MAX_EXPOSURE


def test_with_the_telemetry_drop_in_still_at_most_2_0(tmp_path: Path) -> None:
    unit = _unit_here(tmp_path, TELEMETRY)
    service = unit.read_text().split("[Install]")[0]
    assert "RestrictAddressFamilies=AF_INET AF_INET6" in service
    assert _exposure(unit) <= MAX_EXPOSURE


def test_every_device_the_robot_needs_is_allowed_and_nothing_else_is_open() -> None:
    text = UNIT.read_text(encoding="utf-8")
    assert "DevicePolicy=closed" in text
    allowed = set(re.findall(r"^DeviceAllow=char-(\S+) rw$", text, re.MULTILINE))
    assert {"i2c", "gpiochip", "ttyAMA", "ttyS", "ttyUSB"} <= allowed
    families = re.search(r"^RestrictAddressFamilies=(.*)$", text, re.MULTILINE)
    assert families is not None
    assert set(families.group(1).split()) == {"AF_UNIX", "AF_CAN", "AF_NETLINK"}  # no IP
    assert "RestrictRealtime=no" in text
    assert "LimitRTPRIO=40" in text
    assert "ReadWritePaths=-/sys/devices/platform" in text  # PWM and the IIO DAC in sysfs
