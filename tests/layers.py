"""The stated order of bywire's layers, and the import graph read from the source.

A unit is a package under `src/bywire` or a top-level module. Each layer may import only from
the layers below it: a unit never imports another of its own layer, nor anything above. Imports
under `TYPE_CHECKING` and inside functions count too.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

SOURCE = Path(__file__).resolve().parent.parent / "src" / "bywire"

LAYERS: tuple[frozenset[str], ...] = tuple(
    frozenset(layer.split())
    for layer in (
        "build",  # which build runs (pure or compiled): what the package checks first
        "__init__ errors background",
        "atomic_file quit_keys priority accepting textfile loopback",
        "error_flags can_frame plot_page",  # values and constants every layer may name
        "model",  # commands, reports and their values
        "command_table",  # the command messages the controller obeys, one row each
        "control protocol",  # the pure core; the codecs
        "task_table security",  # the schedule's rows; SecOC sessions
        "config",  # the robot file, read into the core's configurations
        "hal",  # the hardware seam and its backends
        "runtime netbus canlog teleop rc",  # the controller's shell; tools beside it
        "ros2",  # the bridge (its CAN side runs inside `bywire verify`'s bridge campaigns)
        "telemetry sim monitor",
        "replay dashboard",
        "bench",
        "cli",
        "__main__",
    )
)
"""Bottom to top."""


class Import(NamedTuple):
    path: Path  # inside the package: bywire/config/tree.py
    line: int
    importer: str
    imported: str

    def __str__(self) -> str:
        return f"{self.path}:{self.line}: {self.importer} imports {self.imported}"


def unit_of(path: Path, root: Path = SOURCE) -> str:
    return path.relative_to(root).with_suffix("").parts[0]


def imports(root: Path = SOURCE) -> Iterator[Import]:
    """Every import of one unit by another, read from the source."""
    units = {unit_of(path, root) for path in root.rglob("*.py")}
    for path in sorted(root.rglob("*.py")):
        importer = unit_of(path, root)
        where = root.name / path.relative_to(root)
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            for name in _bywire_names(node, units):
                if name != importer:
                    yield Import(where, getattr(node, "lineno", 0), importer, name)


def _bywire_names(node: ast.AST, units: set[str]) -> list[str]:
    if isinstance(node, ast.Import):
        names = [alias.name.split(".") for alias in node.names]
        return [parts[1] for parts in names if parts[0] == "bywire" and len(parts) > 1]
    if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
        parts = node.module.split(".")
        if parts[0] != "bywire":
            return []
        if len(parts) > 1:
            return [parts[1]]
        return [alias.name if alias.name in units else "__init__" for alias in node.names]
    return []


def layer_of(unit: str) -> int:
    for index, layer in enumerate(LAYERS):
        if unit in layer:
            return index
    raise KeyError(unit)


def upward(found: Iterator[Import]) -> list[Import]:
    """The imports that do not run down: to the same layer or above."""
    return [item for item in found if layer_of(item.imported) >= layer_of(item.importer)]
