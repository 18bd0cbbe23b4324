"""The packaged scenarios (`bywire/scenarios/*.toml`) by name, and `--scenario NAME|FILE` lookup."""

from __future__ import annotations

import difflib
from importlib import resources
from importlib.abc import Traversable
from pathlib import Path

from bywire.errors import ConfigError
from bywire.sim.scenario import Scenario, load_scenario, parse_scenario

DEFAULT_SCENARIO = "test-course"
SUFFIX = ".toml"


def _folder() -> Traversable:
    return resources.files("bywire").joinpath("scenarios")


def scenario_names() -> list[str]:
    """Names of the packaged scenarios (file names without .toml), sorted."""
    return sorted(
        entry.name.removesuffix(SUFFIX)
        for entry in _folder().iterdir()
        if entry.is_file() and entry.name.endswith(SUFFIX)
    )


def packaged_scenario(name: str) -> Scenario:
    """One packaged scenario by name (with or without .toml); ConfigError with a suggestion."""
    stem = name.removesuffix(SUFFIX)
    names = scenario_names()
    if stem not in names:
        close = difflib.get_close_matches(stem, names, n=1)
        hint = f" (did you mean '{close[0]}'?)" if close else ""
        raise ConfigError(
            f"unknown scenario {name!r}{hint}; packaged scenarios: {', '.join(names)}"
            " (or give the path of a scenario file)"
        )
    text = _folder().joinpath(stem + SUFFIX).read_text(encoding="utf-8")
    return parse_scenario(text, f"bywire/scenarios/{stem}{SUFFIX}")


def packaged_scenarios() -> dict[str, Scenario]:
    """Every packaged scenario, parsed, by name in name order."""
    return {name: packaged_scenario(name) for name in scenario_names()}


def find_scenario(name_or_path: str) -> Scenario:
    """A scenario file if the argument names one (a path, or an existing file), else by name."""
    path = Path(name_or_path)
    looks_like_path = "/" in name_or_path or path.parent != Path(".")
    if looks_like_path or path.is_file():
        if not path.exists():
            raise ConfigError(f"{name_or_path}: no such file")
        return load_scenario(path)
    stem = name_or_path.removesuffix(SUFFIX)
    if name_or_path.endswith(SUFFIX) and stem not in scenario_names():
        # A file's name, not a packaged scenario's: say what is missing (and what is packaged).
        close = difflib.get_close_matches(stem, scenario_names(), n=1)
        hint = f" (did you mean '{close[0]}'?)" if close else ""
        raise ConfigError(
            f"{name_or_path}: no such file, and no packaged scenario is called {stem!r}{hint};"
            " `bywire sim --list` lists those"
        )
    return packaged_scenario(name_or_path)
