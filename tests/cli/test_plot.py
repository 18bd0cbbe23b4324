"""`bywire plot`: a PNG from the BLF and candump logs of `bywire sim --log`; bad input exits 2."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import pytest
from matplotlib import image

from bywire.cli.main import main
from bywire.plot_page import DPI, SIZE_IN
from tests.canlog import tesla_drive

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
        ("run.xyz", b"", "suffix must be one of"),
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


# --- other people's logs and databases (tests/data; see its README) -----------------------------

DATA = Path(__file__).resolve().parents[1] / "data"
TESLA_DBC = DATA / "opendbc/tesla_model3_party.dbc"
MSXII = (DATA / "cantools/msxii_battery_vt.candump", DATA / "cantools/msxii_system_can.dbc")


def _drawn_fraction(path: Path) -> float:
    pixels = image.imread(path)[:, :, :3]
    return float((pixels.sum(axis=2) < 2.9).mean())


def _coloured_pixels(path: Path) -> int:
    """Pixels of a line colour (not white, grey or black): the data drawn, not the frame."""
    pixels = image.imread(path)[:, :, :3]
    spread = pixels.max(axis=2) - pixels.min(axis=2)
    return int((spread > 0.25).sum())


@pytest.fixture(scope="module")
def tesla_blf(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tesla_drive.write(tmp_path_factory.mktemp("tesla") / "drive.blf")


def test_a_real_car_log_with_its_dbc_draws_its_data(tesla_blf: Path, tmp_path: Path) -> None:
    out = tmp_path / "tesla.png"
    status, stdout, err = _main("plot", str(tesla_blf), "--dbc", str(TESLA_DBC), "--out", str(out))
    assert (status, err) == (0, "")
    assert stdout.strip() == f"Plot: {out}"
    assert out.read_bytes().startswith(PNG_SIGNATURE)
    assert _coloured_pixels(out) > 5000


def test_named_signals_are_drawn_and_only_they(tesla_blf: Path, tmp_path: Path) -> None:
    one, many = tmp_path / "one.png", tmp_path / "many.png"
    argv = ["plot", str(tesla_blf), "--dbc", str(TESLA_DBC)]
    assert _main(*argv, "--signal", "DI_speed.DI_vehicleSpeed", "--out", str(one))[0] == 0
    assert _main(*argv, "--signal", "*wheelSpeed*", "--signal", "SCCM_*.*", "--out", str(many))[
        0
    ] == 0  # fmt: skip
    assert 500 < _coloured_pixels(one) < _coloured_pixels(many)


def test_a_real_vehicle_log_without_timestamps_is_drawn_per_frame(tmp_path: Path) -> None:
    log, database = MSXII
    out = tmp_path / "msxii.png"
    argv = ["plot", str(log), "--dbc", str(database), "--out", str(out)]
    status, _, err = _main(*argv, "--signal", "BATTERY_VT.MODULE_VOLTAGE_*")
    assert (status, err) == (0, "")
    assert _coloured_pixels(out) > 300  # 36 dots, one per module


def test_a_signal_pattern_that_matches_nothing_is_refused_with_a_hint(tesla_blf: Path) -> None:
    status, out, err = _main(
        "plot", str(tesla_blf), "--dbc", str(TESLA_DBC), "--signal", "DI_speed.DI_vehicleSped"
    )
    assert (status, out) == (2, "")
    assert "--signal 'DI_speed.DI_vehicleSped' matches no signal of the DBC" in err
    assert "did you mean DI_speed.DI_vehicleSpeed" in err
    assert err.count("\n") == 1


def test_an_existing_png_is_kept_unless_forced(sim_log: Path, tmp_path: Path) -> None:
    out = tmp_path / "run.png"
    out.write_bytes(b"the user's own picture")
    status, stdout, err = _main("plot", str(sim_log), "--out", str(out))
    assert (status, stdout) == (2, "")
    assert err == (
        f"bywire plot: error: {out} exists: add --force to overwrite it,"
        " or choose another file with --out\n"
    )
    assert out.read_bytes() == b"the user's own picture"
    assert _main("plot", str(sim_log), "--out", str(out), "--force")[0] == 0
    _check_png(out)


def test_a_log_cut_mid_line_plots_what_precedes_and_says_where(tmp_path: Path) -> None:
    log, database = MSXII
    text = log.read_text(encoding="utf-8")
    cut = tmp_path / "cut.candump"
    cut.write_text(text[: len(text) // 2 + 5], encoding="utf-8")
    status, _, err = _main("plot", str(cut), "--dbc", str(database), "--signal", "MODULE_*")
    assert status == 0
    assert err == (
        "bywire plot: warning: cut.candump: line 19 is cut short (the file ends without a"
        " newline): read the 18 lines before it\n"
    )
    assert _drawn_fraction(cut.with_suffix(".png")) > 0.01


def test_a_truncated_blf_plots_what_it_holds(tesla_blf: Path, tmp_path: Path) -> None:
    data = tesla_blf.read_bytes()
    cut = tmp_path / "cut.blf"
    cut.write_bytes(data[: len(data) // 2])
    status, stdout, err = _main("plot", str(cut), "--dbc", str(TESLA_DBC))
    assert status == 0
    assert stdout.strip() == f"Plot: {cut.with_suffix('.png')}"
    assert err.startswith("bywire plot: warning: cut.blf: the file is cut short (")
    assert _coloured_pixels(cut.with_suffix(".png")) > 2000
