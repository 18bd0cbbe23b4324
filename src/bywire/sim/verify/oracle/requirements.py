"""The oracle's own figures: what the requirements (`/work/shared/REQUIREMENTS.md`,
`docs/SAFETY.md`) demand, each named by its requirement's id, never what the robot file under
test configures (R-CONFIG-SAFETY: `verify` judges against the deadlines, not the file).

Two kinds:

- `REQUIRED`, the bounds on the figures from which the oracle's deadlines are built (an input's
  timeout, the watchdog, how long a decision or a DAC write may wait, the standstill threshold,
  the speed check's blind spot). A robot file may promise less (a shorter timeout: it is held to
  its promise, as §8 says, "within the configured timeout"), never more: `Required.bound`. A
  file with slow tasks or a loose speed check is judged as if it kept the requirement, so
  `bywire verify` objects where it breaks it. The input timeouts and the watchdog are the
  file's to set (R-TIMEOUT and R-WATCHDOG give defaults, 100 and 200 ms): the deadline is "within
  its timeout plus one control period", the period the requirement's; a figure past the limits
  the loader states for them (`bywire.config.limits`) is judged at the limit.
- the constants below, what a stop, a brake and a handover must do, whatever the file says (a
  file's own bounds are held within these at load, `bywire.config.deadlines`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from enum import Enum
from types import MappingProxyType

from bywire.config.deadlines import (
    BLIND_SPOT_MPS,
    DAC_FAILURE_DEADLINE_S,
    HYDRO_FAILURE_DEADLINE_S,
    HYDRO_FAILURE_DUTY,
    MAX_CONTROL_PERIOD_S,
    MOST_DAC_TRANSFER_BUDGET_S,
    STANDSTILL_HOLD_MAX_S,
    STEERING_DEVIATION_NORM,
    STUCK_SERVO_DEADLINE_S,
)
from bywire.config.limits import INPUT_TIMEOUT_S, WATCHDOG_S
from bywire.control.dac_health import DAC_FAILURE_LIMIT
from bywire.control.stop import MAX_CONTROLLED_STOP_S, MIN_CONTROLLED_STOP_S, STANDSTILL_LIMIT_MPS
from bywire.protocol import dbc


class Figure(Enum):
    """A figure the oracle's deadlines are built from, which a robot file also sets."""

    RC_TIMEOUT_S = "RC frames' age limit"
    CAN_TIMEOUT_S = "the computer's movement commands' age limit in CAN mode"
    WATCHDOG_S = "the loop stall that forces the safe state"
    CONTROL_PERIOD_S = "how long a decision may wait for its tick, whatever the task rates"
    DRIVING_PERIOD_S = "how long apart the DAC is written (failing writes are counted per write)"
    STANDSTILL_MPS = "below this speed the robot counts as standing still"
    BLIND_SPOT_MPS = "the fastest a wheel sensor may die unnoticed"
    DAC_TRANSFER_S = "the slowest DAC transfer that is no fault (the transfer budget)"


@dataclass(frozen=True, slots=True)
class Required:
    """One requirement's figure: its id in REQUIREMENTS.md and the most it allows."""

    requirement: str
    most: float

    def bound(self, configured: float) -> float:
        """What the oracle judges with: the file's figure, never laxer than the requirement."""
        return min(configured, self.most)


REQUIRED: Mapping[Figure, Required] = MappingProxyType(
    {
        # "RC frames (default 100 ms), CAN commands while in CAN mode (default 100 ms)": the
        # file's own, up to the limit the loader states
        Figure.RC_TIMEOUT_S: Required("R-TIMEOUT", INPUT_TIMEOUT_S.high),
        Figure.CAN_TIMEOUT_S: Required("R-TIMEOUT", INPUT_TIMEOUT_S.high),
        # "if the control loop stalls (default 200 ms)": likewise
        Figure.WATCHDOG_S: Required("R-WATCHDOG", WATCHDOG_S.high),
        # "input loss -> safe within timeout + one period, whatever the task rates"
        Figure.CONTROL_PERIOD_S: Required("R-CONFIG-SAFETY", MAX_CONTROL_PERIOD_S),
        # "persisting failure disables the motors": the failure limit's writes within 60 ms
        Figure.DRIVING_PERIOD_S: Required(
            "R-DAC-FAULT", DAC_FAILURE_DEADLINE_S / DAC_FAILURE_LIMIT
        ),
        # "direction changes only near standstill"
        Figure.STANDSTILL_MPS: Required("R-INTERLOCK", STANDSTILL_LIMIT_MPS),
        # "a bounded plausibility blind spot"
        Figure.BLIND_SPOT_MPS: Required("R-CONFIG-SAFETY", BLIND_SPOT_MPS),
        # "budgets come from deadlines" (issue 41): what the stop promises leave a transfer
        Figure.DAC_TRANSFER_S: Required("R-TIMING", MOST_DAC_TRANSFER_BUDGET_S),
    }
)
"""Every figure a robot file sets that the oracle's deadlines are built from, with its bound."""

CONTROLLED_STOP_LIMIT_S = MAX_CONTROLLED_STOP_S
"""R-STOP-CATEGORY: the longest a controlled stop may keep the drive powered (a robot file's
`[stop] controlled_max_s` is held within it at load)."""
REGEN_WINDOW_S = MIN_CONTROLLED_STOP_S
"""R-STOP-CATEGORY: how long a controlled stop surely keeps its regenerative brake (unless
standing still)."""
STANDSTILL_GRACE_S = STANDSTILL_HOLD_MAX_S + 0.05
"""R-STOP-CATEGORY: standing still this long, with a wheel sensor that tells the truth, ends a
controlled stop: the longest standstill hold a robot file may have (a stop cannot tell a
standstill from a sensor dying inside its blind spot at once), and a reading's lag."""
REQUIRED_DECEL_MPS2 = 1.0
"""R-EBRAKE: the least deceleration of a stop while any brake works (the simulated robot's
weakest brake, regeneration alone with rolling drag, gives 1.65 m/s²)."""
BRAKE_REACT_S = 0.05
"""R-EBRAKE: how long a brake may take to bite once applied."""
REQUIRED_HANDOVER_RATE = 2.0
"""R-SWITCH: how fast a handover may move the steering below 1 m/s (the most a robot file may
set)."""
SLOW_TRANSFER_S = MOST_DAC_TRANSFER_BUDGET_S
"""R-TIMING: a DAC transfer slower than this is no ordinary one (the robot file's budget is at
most this, what the stop promises leave: `bywire.config.deadlines`): STOP, category 0.
Transfers of 2 ms are ordinary and must never stop the robot; transfers within the file's budget
delay no stop past its promise (`OracleTiming.deadline_s`)."""
CAN_PERIOD_S = dbc.command_period_s()
"""R-DBC: the computer's commands' period as the protocol gives it (the DBC, never the robot
file), and a second sender's frames, one a period."""
CAN_STALE_S = CAN_PERIOD_S + 0.005
"""A CAN value may still be what the controller sees a period (and wire time) after it changed."""
TRUST_REGAINED_S = 15 * CAN_PERIOD_S
"""R-CANRX: an id distrusted for a second sender is trusted again only after a window of
good frames, one for each of the rolling counter's 16 values: at least 15 command periods after
the second sender's last frame."""
DAC_LATCH_WRITES = 20
"""R-DAC-FAULT: a DAC failing for this many of the driving task's periods has certainly latched
DAC_FAULT: every other write failing trips the leaky count after eight writes; the rest is
margin."""
FULL_DUTY = 1.0
"""R-HYDRO: the hydraulic brake's duty in STOP."""
PRESSURE_DUTY = HYDRO_FAILURE_DUTY
"""R-MONITORS (docs/SAFETY.md rows 5, 62): with a pressure sensor fitted, a hydraulic brake that
builds no pressure at this duty or more is a fault…"""
PRESSURE_DEADLINE_S = HYDRO_FAILURE_DEADLINE_S
"""…acted on (the e-brake engaged) within this of the duty (the file's `[monitors]` figures are
held within it at load)."""
SERVO_DEVIATION_NORM = STEERING_DEVIATION_NORM
"""R-MONITORS (docs/SAFETY.md rows 7, 50): with a steering encoder fitted, a servo stuck more than
this off the position its pulse asks for is a fault…"""
SERVO_DEADLINE_S = STUCK_SERVO_DEADLINE_S
"""…acted on (the e-brake engaged) within this of the deviation."""
OVER_LIMIT_FRACTION = 0.2
OVER_LIMIT_LEAST_MPS = 0.2
"""Issue 44 (docs/SAFETY.md row 67): with a wheel sensor that tells the truth, the true speed
never exceeds the file's `[limits] max_speed_mps` by more than this fraction of it, and never by
more than `OVER_LIMIT_LEAST_MPS` where that is more (a small overshoot on a slope is allowed, a
runaway is not). The limit is the file's (it is the operator's choice, raised step by step);
the margin is the requirement's."""


def over_limit_margin_mps(limit_mps: float) -> float:
    """How far past a speed limit the robot may ever be (`OVER_LIMIT_FRACTION`)."""
    return max(OVER_LIMIT_FRACTION * limit_mps, OVER_LIMIT_LEAST_MPS)
