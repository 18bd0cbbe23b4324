"""Which build runs: the pure Python package, or the one compiled by mypyc (issue 43).

`BYWIRE_COMPILE=1 pip install .` compiles most modules (setup.py lists them) and writes
`_compiled.json` beside them: the mypyc version, its optimisation level, and the SHA-256 of each
compiled module's source. A compiled module whose `.py` no longer has that hash (an editable
install, edited after the build) is stale: bywire refuses to start rather than run code that is
not what the source says (`check`, called on import of the package).
"""

from __future__ import annotations

import copyreg
import dataclasses
import hashlib
import importlib.machinery
import importlib.util
import json
import sys
from pathlib import Path
from typing import Any

PACKAGE_DIR = Path(__file__).parent
BUILD_INFO = PACKAGE_DIR / "_compiled.json"
"""Written by a compiled build (setup.py), never by hand and never committed."""
PROBE = "bywire.model"
"""A module that every compiled build compiles: it is compiled iff the build is."""
REBUILD = (
    "rebuild it (BYWIRE_COMPILE=1 pip install -e .) or remove the compiled modules"
    " (the .so files beside the sources, and bywire/_compiled.json)"
)


class StaleBuildError(ImportError):
    """Compiled modules that do not match their source: running them would be running other code
    than the source says."""


def is_compiled() -> bool:
    """True when the compiled modules are the ones Python imports."""
    spec = importlib.util.find_spec(PROBE)
    origin = spec.origin if spec is not None else None
    return origin is not None and origin.endswith(tuple(importlib.machinery.EXTENSION_SUFFIXES))


def build_info() -> dict[str, Any] | None:
    """What the compiled build recorded, or None (a pure build)."""
    if not BUILD_INFO.is_file():
        return None
    info: dict[str, Any] = json.loads(BUILD_INFO.read_text(encoding="utf-8"))
    return info


def build_name() -> str:
    """'pure', or 'compiled (mypyc X, -O n)'."""
    if not is_compiled():
        return "pure"
    info = build_info() or {}
    return f"compiled (mypyc {info.get('mypyc', '?')}, -O{info.get('opt_level', '?')})"


def source_hash(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def stale_modules() -> list[str]:
    """The compiled modules whose source differs from the one compiled (all of them when the
    build recorded nothing), by path under the package's parent."""
    info = build_info()
    if info is None:
        return ["bywire/_compiled.json (missing)"]
    root = PACKAGE_DIR.parent
    sources: dict[str, str] = info["sources"]
    stale = []
    for name, digest in sorted(sources.items()):
        path = root / name
        if not path.is_file() or source_hash(path) != digest:
            stale.append(name)
    # and a compiled module this build did not compile (left by an earlier one)
    for path in sorted(PACKAGE_DIR.rglob("*")):
        if path.name.endswith(tuple(importlib.machinery.EXTENSION_SUFFIXES)):
            source = path.parent / (path.name.split(".")[0] + ".py")
            name = source.relative_to(root).as_posix()
            if name not in sources:
                stale.append(path.relative_to(root).as_posix())
    return stale


def check() -> None:
    """StaleBuildError if compiled modules run that do not match their sources; nothing for a pure
    build."""
    if not is_compiled():
        return
    stale = stale_modules()
    if stale:
        raise StaleBuildError(
            f"bywire: the compiled build is stale, its source changed since: {', '.join(stale)};"
            f" {REBUILD}"
        )


def _compiled_module(name: str) -> bool:
    module = sys.modules.get(name)
    origin = getattr(module, "__file__", None) or ""
    return origin.endswith(tuple(importlib.machinery.EXTENSION_SUFFIXES))


def _by_fields(value: Any) -> tuple[type[Any], tuple[Any, ...]]:
    """Pickle a dataclass as its class called with its fields, in order."""
    return type(value), tuple(getattr(value, field.name) for field in dataclasses.fields(value))


def picklable_compiled_dataclasses() -> int:
    """Let pickle carry the compiled dataclasses of every bywire module imported so far, and say
    how many: a process pool's workers send campaigns and outcomes made of them.

    A compiled class is rebuilt by pickle through its `__new__`, which calls `__init__` with no
    arguments, and then by setting each attribute, which a frozen dataclass refuses (issue 43:
    `verify --jobs 2` workers died there). Built instead as the class called with its fields,
    which is what the pure build's value is equal to. Nothing changes for a pure build (no
    module is compiled) nor for a class with a field its `__init__` does not take."""
    registered = 0
    for name in [name for name in sys.modules if name.startswith("bywire.")]:
        if not _compiled_module(name):
            continue
        for value in list(vars(sys.modules[name]).values()):
            if (
                isinstance(value, type)
                and value.__module__ == name
                and dataclasses.is_dataclass(value)
                and all(field.init for field in dataclasses.fields(value))
            ):
                copyreg.pickle(value, _by_fields)
                registered += 1
    return registered
