"""Damaged robot files (tests/toml_mutations.py): `bywire config check` takes each one or refuses
it in one line with exit 2; none gives a traceback or hangs. CI runs a fixed sample (the `ci`
profile is derandomised); `--hypothesis-profile=long` searches ten times as many."""

from __future__ import annotations

import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bywire.config import load_config
from bywire.errors import ConfigError
from tests.toml_mutations import assert_refused_in_one_line, mutated_files, run_bywire

ROOT = Path(__file__).resolve().parents[2]
SEEDS = {
    "albert": (ROOT / "config" / "albert.toml").read_text(encoding="utf-8"),
    "sim": (ROOT / "src" / "bywire" / "defaults" / "sim.toml").read_text(encoding="utf-8"),
}
FILES = 5 * settings().max_examples  # per seed file: 500 on CI, 5,000 with the long profile


@pytest.mark.long
@pytest.mark.parametrize("seed", sorted(SEEDS))
@settings(max_examples=FILES, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_a_damaged_robot_file_is_taken_or_refused_in_one_line(
    seed: str, data: st.DataObject
) -> None:
    content = data.draw(mutated_files(SEEDS[seed]), label="file")
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "robot.toml"
        path.write_bytes(content)
        status, err = run_bywire("config", "check", str(path))
        if status != 0:
            assert_refused_in_one_line("config", status, err)
            with pytest.raises(ConfigError):
                load_config(path)
        else:  # taken: at most warnings of unsafe numbers (`bywire verify` judges them)
            assert all(line.startswith("warning: ") for line in err.splitlines()), err
