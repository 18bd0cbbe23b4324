"""The differential check: every virtual-time scenario and a few dozen verify campaigns leave the
simulated hardware with the histories they left when the digests were stored (bit for bit).

A change meant to be faster, not different, must pass this unchanged. A change meant to change
behaviour stores new digests (`python -m tests.system.differential digests`) and says so.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from bywire.config import RobotConfig
from tests.system.differential import digest, robot_with_fixed_key, runs, stored_digests

RUNS = runs()


@pytest.fixture(scope="module")
def robot(tmp_path_factory: pytest.TempPathFactory) -> RobotConfig:
    folder: Path = tmp_path_factory.mktemp("differential")
    return robot_with_fixed_key(folder)


def test_every_run_has_a_stored_digest() -> None:
    assert sorted(stored_digests()) == sorted(RUNS)


@pytest.mark.parametrize("name", sorted(RUNS))
def test_history_is_unchanged(name: str, robot: RobotConfig) -> None:
    assert digest(RUNS[name](robot)) == stored_digests()[name], (
        f"{name} diverged: `python -m tests.system.differential compare DIR` against a dump of"
        " the code before says where"
    )
