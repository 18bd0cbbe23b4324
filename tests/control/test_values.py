"""`@value` keeps every guarantee of a frozen, slotted dataclass; only construction is faster."""

from __future__ import annotations

import dataclasses

import pytest

from bywire.control.values import value


@value
class Inner:
    a: float
    b: float | None = None


@value
class Outer:
    inner: Inner = dataclasses.field(default_factory=lambda: Inner(1.0))
    items: tuple[int, ...] = ()
    checked: float = 0.0

    def __post_init__(self) -> None:
        if self.checked < 0.0:
            raise ValueError("checked must be >= 0")


def test_fields_are_stored_positionally_and_by_keyword() -> None:
    assert (Inner(1.0, 2.0).a, Inner(1.0, 2.0).b) == (1.0, 2.0)
    assert Inner(b=3.0, a=4.0) == Inner(4.0, 3.0)
    assert Inner(5.0).b is None


def test_a_default_factory_runs_for_each_value() -> None:
    first, second = Outer(), Outer()
    assert first.inner == Inner(1.0)
    assert first.inner is not second.inner
    assert Outer(Inner(2.0)).inner == Inner(2.0)


def test_post_init_runs() -> None:
    with pytest.raises(ValueError, match="checked"):
        Outer(checked=-1.0)


def test_frozen_slotted_hashable_and_replaceable() -> None:
    inner = Inner(1.0, 2.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        inner.a = 3.0  # type: ignore[misc]
    assert not hasattr(inner, "__dict__")
    assert hash(inner) == hash(Inner(1.0, 2.0))
    assert dataclasses.replace(inner, b=5.0) == Inner(1.0, 5.0)
    assert repr(inner) == "Inner(a=1.0, b=2.0)"


def test_missing_and_unknown_arguments_are_refused() -> None:
    with pytest.raises(TypeError):
        Inner()  # type: ignore[call-arg]
    with pytest.raises(TypeError):
        Inner(1.0, c=2.0)  # type: ignore[call-arg]


def test_fields_its_init_cannot_store_are_refused_where_the_class_is_made() -> None:
    with pytest.raises(TypeError, match="Hidden: every field"):

        @value
        class Hidden:
            a: float
            b: float = dataclasses.field(init=False, default=0.0)

    with pytest.raises(TypeError, match="KeywordOnly: every field"):

        @value
        class KeywordOnly:
            a: float = dataclasses.field(kw_only=True, default=0.0)

    with pytest.raises(TypeError, match="WithInitVar: every field"):

        @value
        class WithInitVar:
            a: float
            scale: dataclasses.InitVar[float] = 1.0

            def __post_init__(self, scale: float) -> None:
                pass
