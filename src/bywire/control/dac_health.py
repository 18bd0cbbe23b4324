"""Whether the motor DAC can be trusted to drive what it was told: a pure step per transfer
(R-DAC-FAULT).

Three rules turn failing writes into a hardware fault:

- a leaky count: each failed transfer adds 1, each good one takes `DAC_LEAK` away; reaching the
  limit escalates, and the escalation holds until the count has drained to zero. Three failures
  in a row escalate; so does every other transfer failing (+0.75 a pair), which a count of
  *consecutive* failures never would;
- a failed transfer that should have *lowered* a channel's voltage: the DAC may still drive the
  old, higher voltage, so this alone is a fault until that channel is written successfully;
- a transfer slower than its budget: it landed, but a drive whose every command takes that long
  is not under control; it counts as failures by the budgets it took (`weight`: an 80 ms
  transfer against a 10 ms budget is eight, a 12 ms one is 1.2).

`tests/control/test_dac_health_exhaustive.py` checks every reachable state.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from bywire.control.values import slot_init

DAC_LEAK = 0.25  # one failure is forgiven after four good writes
DAC_FAILURE_LIMIT = 3  # failures in a row (30 ms at 100 Hz) before the DAC counts as failing
DAC_TRANSFERS_PER_PASS = 2
"""A pass writes the drive's two analogue signals, the throttle then the regenerative brake, one
I2C transfer each (`bywire.runtime.actuators.Actuators.write_drive`): what the pass budget must
hold of the transfer budget (`bywire.config.deadlines`)."""


class Transfer(enum.Enum):
    """How one I2C transfer to the DAC went."""

    ACKNOWLEDGED = "acknowledged within its budget"
    FAILED = "not acknowledged (a NAK, a bus error)"
    SLOW = "acknowledged, after more than its budget"


@dataclass(frozen=True, slots=True)
class DacHealth:
    """The leaky level, whether it escalated, the channels whose lowering write failed, and what
    each channel was last told and acknowledged (volts)."""

    level: float = 0.0
    escalated: bool = False
    lowering_failed: frozenset[int] = frozenset()
    acknowledged: tuple[tuple[int, float], ...] = ()

    def __init__(
        self,
        level: float = 0.0,
        escalated: bool = False,
        lowering_failed: frozenset[int] = frozenset(),
        acknowledged: tuple[tuple[int, float], ...] = (),
    ) -> None:
        object.__setattr__(self, "level", level)
        object.__setattr__(self, "escalated", escalated)
        object.__setattr__(self, "lowering_failed", lowering_failed)
        object.__setattr__(self, "acknowledged", acknowledged)

    @property
    def failing(self) -> bool:
        """The DAC cannot be trusted to drive what it was told."""
        return self.escalated or bool(self.lowering_failed)

    def volts(self, channel: int) -> float | None:
        """What `channel` was last told and acknowledged (None before its first good write)."""
        return dict(self.acknowledged).get(channel)


slot_init(DacHealth)


def dac_step(
    health: DacHealth,
    channel: int,
    wanted_volts: float,
    transfer: Transfer,
    *,
    limit: int,
    weight: float = 1.0,
) -> DacHealth:
    """The health after one transfer of `wanted_volts` to `channel`; `weight`: how many
    failures a slow transfer counts as (the budgets it took, at least one)."""
    acknowledged = dict(health.acknowledged)
    lowering = set(health.lowering_failed)
    level, escalated = health.level, health.escalated
    if transfer is Transfer.FAILED:
        level = min(level + 1.0, 2.0 * limit)
        if wanted_volts < acknowledged.get(channel, 0.0):
            lowering.add(channel)
    else:  # it landed: the channel holds what it was told
        acknowledged[channel] = wanted_volts
        lowering.discard(channel)
        if transfer is Transfer.SLOW:
            level = min(level + max(weight, 1.0), 2.0 * limit)
        else:
            level = max(level - DAC_LEAK, 0.0)
    if level >= limit:
        escalated = True
    elif level == 0.0:
        escalated = False
    return DacHealth(level, escalated, frozenset(lowering), tuple(sorted(acknowledged.items())))
