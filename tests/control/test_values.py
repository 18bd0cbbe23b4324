"""`@value` keeps every guarantee of a frozen, slotted dataclass; only construction is faster."""

from __future__ import annotations

import dataclasses

import pytest

from bywire import build
from bywire.control.controller import ControlOutputs, ControlState
from bywire.control.mux import Movement
from bywire.control.values import SOURCE_INITS, slot_init, value
from bywire.sim.observe import Observation
from bywire.sim.verify.oracle.checks.h11 import LimitFacts
from bywire.sim.verify.oracle.outputs import Outputs


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


# `slot_init` (issue 43): the values the compiled build makes native are frozen, slotted
# dataclasses with an `__init__` written out (mypyc compiles it to stores into the struct); in
# the pure build that `__init__` is swapped for `@value`'s, which must store the same.


@dataclasses.dataclass(frozen=True, slots=True)
class Written:
    a: float
    b: float | None = None

    def __init__(self, a: float, b: float | None = None) -> None:
        object.__setattr__(self, "a", a)
        object.__setattr__(self, "b", b)


slot_init(Written)


def test_a_written_init_is_replaced_and_keeps_every_guarantee() -> None:
    assert SOURCE_INITS[Written] is not Written.__init__  # the pure build runs @value's
    assert Written(1.0) == Written(a=1.0, b=None)
    assert (Written(b=3.0, a=4.0).a, Written(b=3.0, a=4.0).b) == (4.0, 3.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        Written(1.0).a = 2.0  # type: ignore[misc]
    assert not hasattr(Written(1.0), "__dict__")
    assert dataclasses.replace(Written(1.0, 2.0), b=5.0) == Written(1.0, 5.0)
    with pytest.raises(TypeError):
        Written()  # type: ignore[call-arg]


def test_the_hot_values_are_native_in_the_compiled_build() -> None:
    # pure: each has its written `__init__` swapped; compiled: each is a native class (mypyc
    # gives it `__mypyc_attrs__`), whatever `@value` would have made of it
    hot = (Movement, ControlOutputs, ControlState, Observation, Outputs, LimitFacts)
    if build.build_name() == "pure":
        assert all(cls in SOURCE_INITS for cls in hot)
    else:
        assert all(hasattr(cls, "__mypyc_attrs__") for cls in hot)


def test_each_written_init_stores_its_fields_as_the_swapped_one_does() -> None:
    # a written `__init__` that computed, reordered or skipped a field would make the two builds
    # differ: both are run with a distinct marker per field, which each field must hold (pure
    # build only: compiled, nothing is swapped and the written `__init__`s are what run)
    if build.build_name() != "pure":
        pytest.skip("compiled: the written __init__ runs, no other to compare with")
    assert len(SOURCE_INITS) >= 30
    for cls, written in SOURCE_INITS.items():
        names = [field.name for field in dataclasses.fields(cls)]
        markers = [object() for _ in names]
        by_source = object.__new__(cls)
        written(by_source, *markers)
        swapped = cls(*markers)
        assert [getattr(by_source, name) for name in names] == markers, cls
        assert [getattr(swapped, name) for name in names] == markers, cls


def test_a_written_init_that_differs_from_the_fields_is_refused() -> None:
    @dataclasses.dataclass(frozen=True, slots=True)
    class OtherDefault:
        a: float = 0.0

        def __init__(self, a: float = 1.0) -> None:
            object.__setattr__(self, "a", a)

    with pytest.raises(TypeError, match="OtherDefault: __init__'s defaults"):
        slot_init(OtherDefault)

    @dataclasses.dataclass(frozen=True, slots=True)
    class Renamed:
        a: float

        def __init__(self, b: float) -> None:
            object.__setattr__(self, "a", b)

    with pytest.raises(TypeError, match="Renamed: every field"):
        slot_init(Renamed)
