"""The DAC backends' rows: each names an opener that exists and has a conformance rig."""

from __future__ import annotations

import importlib
import inspect
from pathlib import Path

import pytest

from bywire.config import parse_config
from bywire.config.dac_backends import DAC_BACKEND_NAMES, DAC_BACKENDS, DacBackend, dac_backend
from bywire.hal.opening import LinuxPaths, preflight
from tests.hal.linux.bench import make_bench
from tests.hal.rigs import DAC_RIGS


@pytest.mark.parametrize("row", DAC_BACKENDS, ids=DAC_BACKEND_NAMES)
def test_each_row_names_a_module_whose_open_dac_takes_section_paths_stack(row: DacBackend) -> None:
    opener = importlib.import_module(row.module).open_dac
    assert len(inspect.signature(opener).parameters) == 3, "open_dac(dac, paths, stack)"


def test_every_backend_runs_the_conformance_suite_and_every_dac_rig_is_a_backend() -> None:
    assert {rig.backend for rig in DAC_RIGS.values()} == set(DAC_BACKEND_NAMES)


def test_the_names_are_distinct() -> None:
    assert len(set(DAC_BACKEND_NAMES)) == len(DAC_BACKENDS)


def test_a_dac_that_does_not_open_says_what_its_backend_needs(tmp_path: Path) -> None:
    bench = make_bench(tmp_path, iio=False)  # no IIO driver and no /dev/i2c-N either
    config = parse_config(bench.config_text())
    problems = dict(preflight(config, LinuxPaths(bench.sysfs, bench.dev)))
    assert f"DAC backend 'auto' needs {dac_backend('auto').needs}" in str(problems["DAC"])
