"""The build backend: setuptools' own, plus mypy (which ships mypyc) when `BYWIRE_COMPILE=1`.

`pip install .` builds the pure package, as always. `BYWIRE_COMPILE=1 pip install .` builds the
compiled one (setup.py says which modules); the compiler is then a build requirement, pinned to
the mypy the tests type-check with, so a compiled build is reproducible.
"""

from __future__ import annotations

import os
import tomllib
from pathlib import Path

from setuptools import build_meta as _setuptools
from setuptools.build_meta import *  # noqa: F403  (the PEP 517 hooks, unchanged)

MYPYC_REQUIREMENT = "mypy==2.4.1"


def _compiling() -> bool:
    return os.environ.get("BYWIRE_COMPILE", "") == "1"


def _compile_requires() -> list[str]:
    """mypyc, and the package's own dependencies: mypyc type-checks the modules it compiles
    against them (cryptography's, rich's types), as `mypy --strict` does in the tests."""
    project = tomllib.loads((Path(__file__).parent.parent / "pyproject.toml").read_text())
    return [MYPYC_REQUIREMENT, *project["project"]["dependencies"]]


def _without_compiling(hook, *args):  # type: ignore[no-untyped-def]
    # setuptools runs setup.py to answer these; nothing is compiled then (mypyc may not be
    # installed yet). The build itself compiles, and fails loudly if mypyc is missing.
    os.environ["BYWIRE_NOT_BUILDING"] = "1"
    try:
        return hook(*args)
    finally:
        del os.environ["BYWIRE_NOT_BUILDING"]


def _requires(hook, config_settings):  # type: ignore[no-untyped-def]
    requires = list(_without_compiling(hook, config_settings))
    return [*requires, *_compile_requires()] if _compiling() else requires


def get_requires_for_build_wheel(config_settings=None):  # type: ignore[no-untyped-def]
    return _requires(_setuptools.get_requires_for_build_wheel, config_settings)


def get_requires_for_build_editable(config_settings=None):  # type: ignore[no-untyped-def]
    return _requires(_setuptools.get_requires_for_build_editable, config_settings)


def prepare_metadata_for_build_wheel(metadata_directory, config_settings=None):  # type: ignore[no-untyped-def]
    return _without_compiling(
        _setuptools.prepare_metadata_for_build_wheel, metadata_directory, config_settings
    )


def prepare_metadata_for_build_editable(metadata_directory, config_settings=None):  # type: ignore[no-untyped-def]
    return _without_compiling(
        _setuptools.prepare_metadata_for_build_editable, metadata_directory, config_settings
    )
