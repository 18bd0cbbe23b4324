"""The oracle's own figures: what the requirements (`docs/SAFETY.md`) demand of a stop, a brake
and a handover, never what the robot file under test configures (a file's own bounds are held
within these at load, `bywire.config.deadlines`)."""

from __future__ import annotations

from bywire.control.stop import MAX_CONTROLLED_STOP_S, MIN_CONTROLLED_STOP_S

CONTROLLED_STOP_LIMIT_S = MAX_CONTROLLED_STOP_S
"""The longest a controlled stop may keep the drive powered (the requirement; a robot file's
`[stop] controlled_max_s` is held within it at load)."""
REGEN_WINDOW_S = MIN_CONTROLLED_STOP_S
"""How long a controlled stop surely keeps its regenerative brake (unless standing still)."""
STANDSTILL_GRACE_S = 0.05
"""Standing still this long, with a wheel sensor that tells the truth, ends a controlled stop."""
REQUIRED_DECEL_MPS2 = 1.0
"""The least deceleration of a stop while any brake works (the simulated robot's weakest brake,
regeneration alone with rolling drag, gives 1.65 m/s²)."""
BRAKE_REACT_S = 0.05
"""How long a brake may take to bite once applied."""
REQUIRED_HANDOVER_RATE = 2.0
"""How fast a handover may move the steering below 1 m/s (the most a robot file may set)."""
SLOW_TRANSFER_S = 0.020
"""A DAC transfer slower than this is no ordinary one (the robot file's budget is at most this):
STOP, category 0. Transfers of 2 ms are ordinary and must never stop the robot."""
CAN_PERIOD_S = 0.020
"""The simulated computer's movement commands, and a second sender's frames, one a period."""
CAN_STALE_S = CAN_PERIOD_S + 0.005
"""A CAN value may still be what the controller sees a period (and wire time) after it changed."""
DAC_LATCH_WRITES = 20
"""A DAC failing for this many of the driving task's periods has certainly latched DAC_FAULT:
every other write failing trips the leaky count after eight writes; the rest is margin."""
FULL_DUTY = 1.0
"""The hydraulic brake's duty in STOP."""
