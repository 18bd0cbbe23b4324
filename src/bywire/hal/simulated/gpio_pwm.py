"""Simulated GPIO lines and PWM channels that record every change with its time (gpiozero-style).

History entries are ``(time_s, value)`` and are appended on the first set and on every change
afterwards, so ``history`` is the waveform a logic analyser would show. A line that was never set
reads low (the pull-downs of the real board), a PWM channel that was never set reads 0 s. For long
runs ``history_limit`` bounds the memory: the oldest entries go, at least the latest
``history_limit`` stay (None keeps everything).
"""

from __future__ import annotations

import bisect
import math
from typing import Generic, TypeVar

from bywire.errors import HardwareError
from bywire.hal.simulated.timers import SimClock

T = TypeVar("T", bool, float)
DEFAULT_HISTORY_LIMIT = 100_000


class _Recorder(Generic[T]):
    """The value of one output, its change history and its write count."""

    def __init__(self, clock: SimClock, initial: T, history_limit: int | None) -> None:
        self._clock = clock
        self._history_limit = history_limit
        self._value: T = initial
        self.history: list[tuple[float, T]] = []
        self.writes = 0
        self.last_write_s: float | None = None

    def record(self, value: T) -> None:
        now_s = self._clock.now()
        self.writes += 1
        self.last_write_s = now_s
        if not self.history or value != self._value:
            self.history.append((now_s, value))
            self._trim()
        self._value = value

    def _trim(self) -> None:
        # In batches, so that appending stays O(1) on average.
        limit = self._history_limit
        if limit is not None and len(self.history) >= 2 * limit:
            del self.history[: len(self.history) - limit]

    @property
    def value(self) -> T:
        return self._value

    def value_at(self, time_s: float, before_first: T) -> T:
        index = bisect.bisect_right(self.history, time_s, key=lambda entry: entry[0])
        return before_first if index == 0 else self.history[index - 1][1]


class SimDigitalOut:
    """A ``DigitalOut`` that remembers its level history."""

    def __init__(
        self, clock: SimClock, name: str = "", history_limit: int | None = DEFAULT_HISTORY_LIMIT
    ) -> None:
        self.name = name
        self._recorder: _Recorder[bool] = _Recorder(clock, False, history_limit)
        self.dead = False
        """Every write raises (a broken driver, a loose connector): `fail()` / `restore()`."""

    def set(self, level: bool) -> None:
        if self.dead:
            raise HardwareError(f"GPIO line {self.name or '?'}: write failed (simulated dead line)")
        self._recorder.record(bool(level))

    def fail(self) -> None:
        """From now on every write raises HardwareError and the level stays where it was."""
        self.dead = True

    def restore(self) -> None:
        self.dead = False

    @property
    def level(self) -> bool:
        """The level driven now (low before the first set)."""
        return self._recorder.value

    @property
    def history(self) -> list[tuple[float, bool]]:
        """``(time_s, level)`` for the first set and every change."""
        return self._recorder.history

    @property
    def writes(self) -> int:
        """Every ``set`` call, changing or not."""
        return self._recorder.writes

    @property
    def last_write_s(self) -> float | None:
        """Time of the latest ``set`` call, None before any."""
        return self._recorder.last_write_s

    def level_at(self, time_s: float) -> bool:
        """The level the line had at ``time_s``."""
        return self._recorder.value_at(time_s, before_first=False)


class SimPwmChannel:
    """A ``PwmChannel`` with a fixed period that remembers its pulse-width history.

    A pulse outside 0…period (or NaN) raises HardwareError, as the Linux sysfs PWM driver
    refuses a duty cycle longer than the period with EINVAL.
    """

    def __init__(
        self,
        clock: SimClock,
        period_s: float,
        name: str = "",
        history_limit: int | None = DEFAULT_HISTORY_LIMIT,
    ) -> None:
        if not 0.0 < period_s < math.inf:
            raise ValueError(f"PWM period_s must be a finite time > 0, got {period_s}")
        self.name = name
        self._period_s = period_s
        self._recorder: _Recorder[float] = _Recorder(clock, 0.0, history_limit)
        self.dead = False
        """Every write raises (a broken driver, a loose connector): `fail()` / `restore()`."""

    def fail(self) -> None:
        """From now on every write raises HardwareError and the pulse stays where it was."""
        self.dead = True

    def restore(self) -> None:
        self.dead = False

    @property
    def period_s(self) -> float:
        return self._period_s

    def set_pulse(self, pulse_s: float) -> None:
        if self.dead:
            raise HardwareError(f"PWM {self.name or 'channel'}: write failed (simulated dead line)")
        if not 0.0 <= pulse_s <= self._period_s:
            raise HardwareError(
                f"PWM {self.name or 'channel'}: pulse {pulse_s} s is outside 0..{self._period_s} s"
            )
        self._recorder.record(float(pulse_s))

    @property
    def pulse_s(self) -> float:
        """The pulse width now (0 before the first set)."""
        return self._recorder.value

    @property
    def duty(self) -> float:
        """Pulse width over period, 0…1."""
        return self._recorder.value / self._period_s

    @property
    def history(self) -> list[tuple[float, float]]:
        """``(time_s, pulse_s)`` for the first set and every change."""
        return self._recorder.history

    @property
    def writes(self) -> int:
        """Every ``set_pulse`` call, changing or not."""
        return self._recorder.writes

    @property
    def last_write_s(self) -> float | None:
        """Time of the latest ``set_pulse`` call, None before any."""
        return self._recorder.last_write_s

    def pulse_at(self, time_s: float) -> float:
        """The pulse width the channel had at ``time_s``."""
        return self._recorder.value_at(time_s, before_first=0.0)
