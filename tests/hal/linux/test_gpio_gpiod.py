"""libgpiod backend on the gpiod stand-in: chips by label, lines by name or offset, requested
low in the request itself, one request per chip, clear errors, low again on close."""

from __future__ import annotations

from pathlib import Path

import pytest

from bywire.errors import HardwareError
from bywire.hal.linux import gpio_gpiod
from bywire.hal.linux.gpio_gpiod import GpiodOutputs, LineSpec, find_gpio_chip
from tests.hal.linux import fake_gpiod


@pytest.fixture
def dev(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setattr(gpio_gpiod, "gpiod", fake_gpiod)
    fake_gpiod.make_chip(tmp_path / "gpiochip0", "pinctrl-bcm2711", [f"GPIO{n}" for n in range(58)])
    fake_gpiod.make_chip(tmp_path / "gpiochip1", "raspberrypi-exp-gpio", ["BT_ON", "WL_ON"])
    return tmp_path


@pytest.mark.parametrize("spec", ["pinctrl-bcm2711", "gpiochip0"])
def test_a_chip_is_found_by_label_or_name(dev: Path, spec: str) -> None:
    assert find_gpio_chip(dev, spec) == dev / "gpiochip0"


def test_an_unknown_chip_lists_labels(dev: Path) -> None:
    with pytest.raises(HardwareError, match=r"found: gpiochip0 = pinctrl-bcm2711, gpiochip1 = "):
        find_gpio_chip(dev, "pinctrl-rp1")


def test_lines_by_name_and_offset_start_low_and_follow_sets(dev: Path) -> None:
    outputs = GpiodOutputs(
        {
            "enable": LineSpec("drive.motors_enable", "pinctrl-bcm2711", "GPIO5"),
            "ebrake": LineSpec("ebrake.ebrake_release", "pinctrl-bcm2711", 17),
            "led": LineSpec("lights.error_led", str(dev / "gpiochip1"), "WL_ON"),
        },
        dev,
    )
    main, expander = (
        fake_gpiod.read_state(dev / "gpiochip0"),
        fake_gpiod.read_state(dev / "gpiochip1"),
    )
    assert main["requested"] == {"GPIO5": 0, "GPIO17": 0}  # low from the request on: no glitch
    assert (main["consumer"], expander["requested"]) == ("bywire", {"WL_ON": 0})
    outputs.lines["ebrake"].set(True)
    assert fake_gpiod.read_state(dev / "gpiochip0")["levels"] == {"GPIO5": 0, "GPIO17": 1}
    outputs.close()
    outputs.close()
    state = fake_gpiod.read_state(dev / "gpiochip0")
    assert (state["levels"], state["released"]) == ({"GPIO5": 0, "GPIO17": 0}, True)
    with pytest.raises(HardwareError, match=r"ebrake\.ebrake_release: cannot set"):
        outputs.lines["ebrake"].set(True)


def test_an_unknown_line_names_its_key(dev: Path) -> None:
    with pytest.raises(
        HardwareError, match=r"GPIO lights.low_beam: no line 'GPIO99' on .*gpioinfo"
    ):
        GpiodOutputs({"low_beam": LineSpec("lights.low_beam", "gpiochip0", "GPIO99")}, dev)


def test_one_line_given_twice_is_refused_and_nothing_stays_requested(dev: Path) -> None:
    specs = {
        "a": LineSpec("drive.motors_forward", "gpiochip1", "BT_ON"),
        "b": LineSpec("drive.motors_enable", "gpiochip0", "GPIO5"),
        "c": LineSpec("drive.motors_reverse", "gpiochip0", 5),
    }
    with pytest.raises(
        HardwareError, match=r"motors_enable and drive\.motors_reverse are both line 5"
    ):
        GpiodOutputs(specs, dev)
    assert fake_gpiod.read_state(dev / "gpiochip1")["released"] is True


def test_a_missing_chip_path_says_so(dev: Path) -> None:
    with pytest.raises(HardwareError, match="gpiochip9 does not exist"):
        GpiodOutputs({"a": LineSpec("drive.motors_enable", str(dev / "gpiochip9"), 1)}, dev)


# --- the E-stop's input (issue 44), requested beside the outputs ---------------------------


def _with_estop(dev: Path) -> GpiodOutputs:
    return GpiodOutputs(
        {"ebrake": LineSpec("ebrake.ebrake_release", "pinctrl-bcm2711", 17)},
        dev,
        {"estop": LineSpec("estop.line", "pinctrl-bcm2711", "GPIO4")},
    )


def test_the_estop_input_is_pulled_down_with_edges_and_reads_its_level(dev: Path) -> None:
    lines = _with_estop(dev)
    state = fake_gpiod.read_state(dev / "gpiochip0")
    assert state["inputs"] == {"GPIO4": ["PULL_DOWN", "BOTH"]}  # nothing connected reads low
    assert state["requested"]["GPIO17"] == 0
    estop = lines.inputs["estop"]
    assert estop.get() is False  # an open circuit: pressed
    fake_gpiod.drive_input(dev / "gpiochip0", "GPIO4", high=True)
    assert estop.get() is True  # released: a rising edge only, and the level high


def test_a_low_between_two_reads_reads_low_once(dev: Path) -> None:
    lines = _with_estop(dev)
    chip = dev / "gpiochip0"
    fake_gpiod.drive_input(chip, "GPIO4", high=True)
    estop = lines.inputs["estop"]
    assert estop.get() is True
    fake_gpiod.drive_input(chip, "GPIO4", high=False)  # a 1 ms press, between two reads
    fake_gpiod.drive_input(chip, "GPIO4", high=True)
    assert estop.get() is False  # not missed
    assert estop.get() is True


def test_closing_drives_the_outputs_low_beside_an_input(dev: Path) -> None:
    lines = _with_estop(dev)
    lines.lines["ebrake"].set(True)
    lines.close()
    state = fake_gpiod.read_state(dev / "gpiochip0")
    assert (state["levels"]["GPIO17"], state["released"]) == (0, True)
    with pytest.raises(HardwareError, match=r"estop\.line: cannot read"):
        lines.inputs["estop"].get()


def test_a_chip_without_interrupts_reads_the_estop_by_level_and_says_so(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """User-mode Linux's gpio-sim has no interrupts: the kernel refuses edge detection (ENODEV),
    and `bywire run` once refused to start ("/dev/gpiochip1 does not exist")."""
    monkeypatch.setattr(gpio_gpiod, "gpiod", fake_gpiod)
    chip = fake_gpiod.make_chip(
        tmp_path / "gpiochip0", "sim", ["EBRAKE", "ESTOP"], interrupts=False
    )
    lines = GpiodOutputs(
        {"ebrake": LineSpec("ebrake.ebrake_release", "sim", "EBRAKE")},
        tmp_path,
        {"estop": LineSpec("estop.line", "sim", "ESTOP")},
    )
    assert fake_gpiod.read_state(chip)["inputs"] == {"ESTOP": ["PULL_DOWN", "NONE"]}
    assert "GPIO estop.line: " in caplog.text
    assert "no edge events" in caplog.text
    estop = lines.inputs["estop"]
    assert estop.get() is False  # still pulled down: an open circuit is a press
    fake_gpiod.drive_input(chip, "ESTOP", high=True)
    assert estop.get() is True


def test_a_chip_without_interrupts_and_no_input_still_fails_as_the_kernel_says(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(gpio_gpiod, "gpiod", fake_gpiod)
    fake_gpiod.make_chip(tmp_path / "gpiochip0", "sim", ["EBRAKE"], interrupts=False)
    lines = GpiodOutputs({"ebrake": LineSpec("ebrake.ebrake_release", "sim", "EBRAKE")}, tmp_path)
    assert lines.inputs == {}  # outputs ask for no edges: nothing to refuse
