"""The DAC backends' rows: each names an opener that exists and has a conformance rig."""

from __future__ import annotations

import importlib
import inspect

import pytest

from bywire.config.dac_backends import DAC_BACKEND_NAMES, DAC_BACKENDS, DacBackend
from tests.hal.rigs import DAC_RIGS


@pytest.mark.parametrize("row", DAC_BACKENDS, ids=DAC_BACKEND_NAMES)
def test_each_row_names_a_module_whose_open_dac_takes_section_paths_stack(row: DacBackend) -> None:
    opener = importlib.import_module(row.module).open_dac
    assert list(inspect.signature(opener).parameters) == ["dac", "paths", "stack"]


def test_every_backend_runs_the_conformance_suite_and_every_dac_rig_is_a_backend() -> None:
    assert {rig.backend for rig in DAC_RIGS.values()} == set(DAC_BACKEND_NAMES)


def test_the_names_are_distinct() -> None:
    assert len(set(DAC_BACKEND_NAMES)) == len(DAC_BACKENDS)
