"""The monkeypatch of the tests (`tests/compiled.py`): on the compiled build a test that replaces
compiled code is skipped, saying what it replaced; anything else is patched as pytest does."""

from __future__ import annotations

import importlib.machinery
import sys
import types
from collections.abc import Iterator

import pytest

from tests.compiled import CompiledAwareMonkeyPatch, replaces_compiled_code

SO = importlib.machinery.EXTENSION_SUFFIXES[0]


class Native:
    def step(self) -> int:
        return 1

    @classmethod
    def made(cls) -> int:
        return 2


@pytest.fixture
def compiled() -> Iterator[types.ModuleType]:
    """A module that looks compiled (its file an extension), with a function, a class, a value."""
    module = types.ModuleType("bywire.fake_compiled")
    module.__file__ = f"/site-packages/bywire/fake_compiled{SO}"
    module.LIMIT = 3  # type: ignore[attr-defined]
    module.step = lambda: 1  # type: ignore[attr-defined]
    Native.__module__ = module.__name__
    module.Native = Native  # type: ignore[attr-defined]
    sys.modules[module.__name__] = module
    yield module
    del sys.modules[module.__name__]
    Native.__module__ = __name__


def test_a_function_a_method_or_a_class_of_a_compiled_module_is_compiled_code(
    compiled: types.ModuleType,
) -> None:
    assert replaces_compiled_code(compiled, "step") == "bywire.fake_compiled.step"
    assert replaces_compiled_code(compiled, "Native") == "bywire.fake_compiled.Native"
    assert replaces_compiled_code(Native, "step") == "bywire.fake_compiled.Native.step"
    assert replaces_compiled_code(Native, "made") == "bywire.fake_compiled.Native.made"


def test_a_value_a_pure_module_or_a_dotted_name_is_not(compiled: types.ModuleType) -> None:
    assert replaces_compiled_code(compiled, "LIMIT") is None  # read from the module's globals
    assert replaces_compiled_code(compiled, "missing") is None
    assert replaces_compiled_code(pytest, "skip") is None
    assert replaces_compiled_code(sys.modules[__name__], "Native") is None
    assert replaces_compiled_code("bywire.fake_compiled.step", "x") is None


def test_replacing_compiled_code_skips_the_test_naming_it(compiled: types.ModuleType) -> None:
    patch = CompiledAwareMonkeyPatch()
    with pytest.raises(pytest.skip.Exception, match=r"replaces bywire\.fake_compiled\.step,"):
        patch.setattr(compiled, "step", lambda: 2)
    assert compiled.step() == 1  # not replaced
    patch.setattr(compiled, "LIMIT", 4)  # a value is patched and given back
    assert compiled.LIMIT == 4
    patch.undo()
    assert compiled.LIMIT == 3
