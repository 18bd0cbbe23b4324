"""Scenario lookup: packaged scenarios by name (with a suggestion when mistyped) or a file path."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from bywire.errors import ConfigError
from bywire.sim import catalog
from bywire.sim.scenario import parse_scenario

ROOT = Path(__file__).resolve().parents[2]
SMALL = 'name = "mine"\nduration_s = 1.5\n[[event]]\nat_s = 0.5\nrc = { mode = "stop" }\n'


def test_packaged_names_are_sorted_file_stems_including_the_test_course() -> None:
    names = catalog.scenario_names()
    assert "test-course" in names
    assert names == sorted(names)
    assert not any(name.endswith(".toml") for name in names)


def test_every_packaged_scenario_parses_and_is_named_like_its_file() -> None:
    for name, scenario in catalog.packaged_scenarios().items():
        assert scenario.name == name  # --list shows file names; a different `name` would confuse
        assert scenario.duration_s > 0


@pytest.mark.parametrize("name", ["test-course", "test-course.toml"])
def test_a_packaged_scenario_is_found_with_or_without_suffix(name: str) -> None:
    scenario = catalog.find_scenario(name)
    assert scenario.name == "test-course"
    assert scenario.duration_s == 40.0
    assert any(event.label == "STOP" for event in scenario.events)


def test_an_unknown_name_suggests_the_nearest_and_lists_the_rest() -> None:
    with pytest.raises(ConfigError) as raised:
        catalog.find_scenario("test-cource")
    message = str(raised.value)
    assert "did you mean 'test-course'" in message
    assert all(name in message for name in catalog.scenario_names())


def test_a_name_with_nothing_close_still_lists_the_packaged_scenarios() -> None:
    with pytest.raises(ConfigError, match=r"packaged scenarios: .*test-course") as raised:
        catalog.find_scenario("zzzzzz")
    assert "did you mean" not in str(raised.value)


def test_a_path_is_read_as_a_file(tmp_path: Path) -> None:
    path = tmp_path / "mine.toml"
    path.write_text(SMALL, encoding="utf-8")
    assert catalog.find_scenario(str(path)).name == "mine"


def test_a_bare_file_name_in_the_working_folder_wins_over_the_catalog(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "test-course.toml").write_text(SMALL, encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    assert catalog.find_scenario("test-course.toml").name == "mine"
    assert catalog.find_scenario("test-course").name == "test-course"


def test_a_missing_path_is_a_config_error_naming_it(tmp_path: Path) -> None:
    missing = tmp_path / "nope" / "gone.toml"
    with pytest.raises(ConfigError, match=r"gone\.toml"):
        catalog.find_scenario(str(missing))


def test_the_readme_scenario_example_is_a_valid_scenario() -> None:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    section = readme.split("## Scenarios", 1)[1]
    example = re.search(r"```toml\n(.*?)```", section, flags=re.DOTALL)
    assert example is not None
    scenario = parse_scenario(example.group(1), "README.md")
    assert scenario.events[-1].values["fault"] == "rc_link_lost"
    assert scenario.expectations[0].after == "unplugged"


@pytest.mark.parametrize(
    ("given", "message"),
    [
        ("nosuch.toml", "nosuch.toml: no such file, and no packaged scenario is called 'nosuch';"),
        ("test-corse.toml", "no such file, and no packaged scenario is called 'test-corse' (did"),
        ("mine/nosuch.toml", "mine/nosuch.toml: no such file"),
    ],
)
def test_a_file_that_is_not_there_is_no_such_file(given: str, message: str) -> None:
    """Issue 32, defect 9: `--scenario nosuch.toml` said "unknown scenario"."""
    with pytest.raises(ConfigError) as raised:
        catalog.find_scenario(given)
    assert message in str(raised.value)
    assert "unknown scenario" not in str(raised.value)
