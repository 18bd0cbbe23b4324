"""Damaged scenario files (tests/toml_mutations.py): `bywire sim --scenario FILE` takes each one or
refuses it in one line with exit 2, before the run; none gives a traceback or runs forever. CI
runs a fixed sample (the `ci` profile is derandomised); `--hypothesis-profile=long` searches ten
times as many."""

from __future__ import annotations

import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bywire.errors import ConfigError
from bywire.sim.scenario import load_scenario
from tests.toml_mutations import assert_refused_in_one_line, mutated_files, run_bywire

FOLDER = Path(__file__).resolve().parents[2] / "src" / "bywire" / "scenarios"
SEEDS = (
    "test-course",
    "can-impostor-authenticated",
    "latch-causes",
    "dac-stall-watchdog",
    "rc-link-lost",
)
FILES = 2 * settings().max_examples  # per seed file: 200 on CI, 2,000 with the long profile
TAKEN = (0, 1)  # the scenario ran (1: an expectation failed, or was not reached)


@pytest.mark.long
@pytest.mark.parametrize("seed", SEEDS)
@settings(max_examples=FILES, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_a_damaged_scenario_is_taken_or_refused_in_one_line(seed: str, data: st.DataObject) -> None:
    text = (FOLDER / f"{seed}.toml").read_text(encoding="utf-8")
    content = data.draw(mutated_files(text), label="file")
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "scenario.toml"
        path.write_bytes(content)
        # A short run: the loader is under test, and a file it takes must start.
        status, err = run_bywire("sim", "--scenario", str(path), "--duration", "0.01", "--json")
        if status not in TAKEN:
            assert_refused_in_one_line("sim", status, err)
            with pytest.raises(ConfigError):
                load_scenario(path)
