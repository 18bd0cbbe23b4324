"""`bywire plot`: a PNG from the BLF and candump logs of `bywire sim --log`; bad input exits 2."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import pytest
from matplotlib import image

from bywire.cli.main import main
from bywire.sim.plot import DPI, SIZE_IN

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _main(*argv: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main(list(argv))
    return status, out.getvalue(), err.getvalue()


@pytest.fixture(scope="module", params=[".blf", ".log"])
def sim_log(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("plot") / f"run{request.param}"
    status, _, err = _main("sim", "--duration", "4", "--log", str(path), "--json")
    assert status == 0, err
    return path


def _check_png(path: Path) -> None:
    data = path.read_bytes()
    assert data.startswith(PNG_SIGNATURE)
    size = (int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big"))
    assert size == (round(SIZE_IN[0] * DPI), round(SIZE_IN[1] * DPI))
    pixels = image.imread(path)[:, :, :3]
    assert (pixels.sum(axis=2) < 2.9).mean() > 0.03  # drawn, not an empty canvas
    colours = {tuple(pixel) for pixel in pixels[::7, ::7].reshape(-1, 3).round(1).tolist()}
    assert len(colours) > 10  # several coloured series and lanes


def test_a_sim_log_becomes_a_png_next_to_it(sim_log: Path) -> None:
    status, out, err = _main("plot", str(sim_log))
    assert (status, err) == (0, "")
    png = sim_log.with_suffix(".png")
    assert out.strip() == f"Plot: {png}"
    _check_png(png)


def test_out_and_dbc_choose_the_file_and_the_database(sim_log: Path, tmp_path: Path) -> None:
    dbc_file = Path(__file__).resolve().parents[2] / "src/bywire/protocol/albert.dbc"
    out = tmp_path / "chosen.png"
    status, _, err = _main("plot", str(sim_log), "--out", str(out), "--dbc", str(dbc_file))
    assert (status, err) == (0, "")
    _check_png(out)


@pytest.mark.parametrize(
    ("name", "content", "message"),
    [
        ("run.txt", b"", "suffix must be one of"),
        ("missing.blf", None, "no such CAN log"),
        ("broken.blf", b"\x00" * 10, "not a readable .blf CAN log"),
    ],
)
def test_a_bad_log_is_one_line_and_exit_2(
    name: str, content: bytes | None, message: str, tmp_path: Path
) -> None:
    path = tmp_path / name
    if content is not None:
        path.write_bytes(content)
    status, out, err = _main("plot", str(path))
    assert (status, out) == (2, "")
    assert err.count("\n") == 1
    assert err.startswith("bywire plot: error:")
    assert message in err
    assert not path.with_suffix(".png").exists()


def test_an_out_file_that_is_no_png_is_refused(sim_log: Path, tmp_path: Path) -> None:
    status, _, err = _main("plot", str(sim_log), "--out", str(tmp_path / "run.jpg"))
    assert status == 2
    assert "suffix must be .png" in err
