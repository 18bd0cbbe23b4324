"""Tests on the compiled build (issue 43, docs/COMPILED.md): a test that puts a function, method
or class of its own into a compiled module is skipped there, saying so.

Compiled callers call a compiled function directly, not through the module's attribute, so the
replacement never runs: a test that re-introduces a bug that way (tests/system/old_bugs.py,
the verifier's teeth) or makes a campaign crash that way would check nothing. Its logic is the
same code in either build, and the main suite runs it on the pure build. Replacing a value (a
limit, a table) is not skipped: mypyc reads a module's variables from its globals.
"""

from __future__ import annotations

import importlib.machinery
import inspect
import sys
from typing import Any

import pytest

NOTSET: Any = object()


def compiled_module(name: str) -> bool:
    """True when bywire's module `name` is imported from a compiled extension."""
    origin = getattr(sys.modules.get(name), "__file__", None) or ""
    return name.startswith("bywire.") and origin.endswith(
        tuple(importlib.machinery.EXTENSION_SUFFIXES)
    )


def replaces_compiled_code(target: object, name: str) -> str | None:
    """'module.name' when setting `name` on `target` replaces a function, method or class of a
    compiled bywire module (or of a class defined in one), else None."""
    if isinstance(target, str):
        return None
    module = target.__name__ if inspect.ismodule(target) else getattr(target, "__module__", "")
    if not (isinstance(module, str) and compiled_module(module)):
        return None
    current = inspect.getattr_static(target, name, None)
    if isinstance(current, classmethod | staticmethod):
        current = current.__func__
    if not (callable(current) or inspect.isdatadescriptor(current)):
        return None
    owner = "" if inspect.ismodule(target) else f"{getattr(target, '__qualname__', '?')}."
    return f"{module}.{owner}{name}"


class CompiledAwareMonkeyPatch(pytest.MonkeyPatch):  # type: ignore[misc]  # final: for typing
    """pytest's monkeypatch, skipping the test when it would replace compiled code."""

    def setattr(
        self, target: Any, name: Any = NOTSET, value: Any = NOTSET, raising: bool = True
    ) -> None:
        if value is not NOTSET:
            replaced = replaces_compiled_code(target, name)
            if replaced is not None:
                pytest.skip(
                    f"replaces {replaced}, which compiled callers call directly: a test of"
                    " the pure build (docs/COMPILED.md)"
                )
            super().setattr(target, name, value, raising=raising)
        else:
            super().setattr(target, name, raising=raising)
