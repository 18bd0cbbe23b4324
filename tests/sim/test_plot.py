"""The run plot: a PNG of the expected size with real content, and refusals before any drawing."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from matplotlib import image

from bywire.config import default_sim_config
from bywire.errors import ConfigError
from bywire.plot_page import DPI, SIZE_IN
from bywire.sim import plot
from bywire.sim.catalog import find_scenario
from bywire.sim.runner import SimRun

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def short_run() -> SimRun:
    run = SimRun(default_sim_config(), find_scenario("test-course"), duration_s=2.0)
    run.run()
    return run


def test_a_run_becomes_a_png_of_the_configured_size_with_drawn_panels(
    short_run: SimRun, tmp_path: Path
) -> None:
    path = tmp_path / "run.png"
    plot.write_plot(short_run, path)
    data = path.read_bytes()
    assert data.startswith(PNG_SIGNATURE)
    width_px = int.from_bytes(data[16:20], "big")
    height_px = int.from_bytes(data[20:24], "big")
    assert (width_px, height_px) == (
        round(SIZE_IN[0] * DPI),
        round(SIZE_IN[1] * DPI),
    )
    pixels = image.imread(path)[:, :, :3]
    not_white = (pixels.sum(axis=2) < 2.9).mean()
    assert not_white > 0.03  # lines, labels, lanes: not an empty canvas
    colours = {tuple(pixel) for pixel in pixels[::7, ::7].reshape(-1, 3).round(1).tolist()}
    assert len(colours) > 10  # several coloured series, not one


@pytest.mark.parametrize("name", ["run.jpg", "run.PNG.txt", "run"])
def test_only_png_is_accepted(name: str, tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"suffix must be \.png"):
        plot.check_plot_path(tmp_path / name)


def test_a_missing_folder_is_refused_before_the_run(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="does not exist"):
        plot.check_plot_path(tmp_path / "missing" / "run.png")


def test_a_run_that_recorded_nothing_is_refused(tmp_path: Path) -> None:
    never_run = SimRun(default_sim_config(), find_scenario("test-course"))
    with pytest.raises(ConfigError, match="nothing to plot"):
        plot.write_plot(never_run, tmp_path / "run.png")
    assert not (tmp_path / "run.png").exists()


def test_the_sim_command_loads_matplotlib_only_to_draw() -> None:
    """`bywire sim` without `--plot` should not pay matplotlib's start-up (0.4 s, 45 MB)."""
    probe = "import sys, bywire.cli.sim\nprint('matplotlib' in sys.modules)\n"
    loaded = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, check=True
    ).stdout.split()
    assert loaded == ["False"]
