"""A simulated operator calibrating: every stick to both ends, every switch through its positions.

`bywire rc --sim` shows the simulated FlySky transmitter and receiver of `bywire sim`
(`hal.simulated.rc_transmitter`: real IBUS frames every 7.7 ms on a simulated 115200-baud line)
moved by this script, over and over (one sweep takes `SWEEP_S`): at rest, the steering stick to full
left, full right and back, the same with the throttle stick, the mode switch low → middle → high
→ middle → low, the gear switch through its positions, each light switch on and off; each
position held `HOLD_S`. The transmitter knows nothing of the robot file but which channel does
what: its sticks and switches span `travel` of the standard 1000…2000 µs (1.0 is 100 %; 0.5, a
transmitter whose travel is set to 50 %, is the issue's 1250 µs STOP that bare thresholds read
as RC). The sticks jitter by ±`JITTER_RAW` µs, as a receiver's do.
"""

from __future__ import annotations

import random
import time
from collections.abc import Sequence
from itertools import pairwise

from bywire.control.rc_mapping import RcMapping, SwitchCalibration
from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.rc_transmitter import CENTRE_RAW, SimRcTransmitter
from bywire.hal.simulated.timers import PeriodicTimer
from bywire.hal.simulated.uart import SimUart
from bywire.model import ControlMode, Gear
from bywire.protocol import ibus

FULL_TRAVEL_RAW = 500  # µs from the centre at 100 % travel
HOLD_S = 0.4  # each switch position; ~50 frames, well above a rest's 13
STICK_KNOTS = ((0.0, 0.0), (0.5, -1.0), (1.5, 1.0), (2.0, 0.0), (2.5, 0.0))  # (s, stick), linear
STICK_S = STICK_KNOTS[-1][0]
REST_S = 0.5  # everything at rest before the sweep starts again
MODE_SWEEP = (0, 1, 2, 1, 0)  # physical positions, low to high
GEAR_SWEEP = (0, 1, 2, 1)
JITTER_RAW = 2
SWEEP_S = REST_S + 2 * STICK_S + HOLD_S * (len(MODE_SWEEP) + len(GEAR_SWEEP) + 4)
MOVE_LEAD_S = 0.001  # the sticks move this long before each frame samples them


def stick_at(t_s: float) -> float:
    """The stick's deflection `t_s` into its part of the sweep (−1…1)."""
    for (t0, v0), (t1, v1) in pairwise(STICK_KNOTS):
        if t0 <= t_s < t1:
            return v0 + (v1 - v0) * (t_s - t0) / (t1 - t0)
    return 0.0


def switch_raw(physical: int, count: int, travel: float) -> int:
    """The pulse of a `count`-position switch in its `physical` position (0 is the lowest)."""
    step = 2 * FULL_TRAVEL_RAW * travel / (count - 1)
    return round(CENTRE_RAW - FULL_TRAVEL_RAW * travel + physical * step)


def _physical(logical: int, switch: SwitchCalibration) -> int:
    return len(switch.positions_raw) - 1 - logical if switch.reverse else logical


def sweep_channels(t_s: float, mapping: RcMapping, travel: float) -> tuple[int, ...]:
    """The 14 pulses the transmitter sends `t_s` into the sweep (repeating every `SWEEP_S`)."""
    steering = pedal = 0.0
    mode = _physical(mapping.mode_positions.index(ControlMode.STOP), mapping.mode_switch)
    gear = _physical(mapping.gear_positions.index(Gear.NEUTRAL), mapping.gear_switch)
    lights = {"low_beam": _physical(0, mapping.low_beam_switch)}
    lights["hazard"] = _physical(0, mapping.hazard_switch)
    t = (t_s % SWEEP_S) - REST_S
    if 0.0 <= t < STICK_S:
        steering = stick_at(t)
    elif 0.0 <= (t := t - STICK_S) < STICK_S:
        pedal = stick_at(t)
    elif 0.0 <= (t := t - STICK_S) < HOLD_S * len(MODE_SWEEP):
        mode = MODE_SWEEP[int(t / HOLD_S)]
    elif 0.0 <= (t := t - HOLD_S * len(MODE_SWEEP)) < HOLD_S * len(GEAR_SWEEP):
        gear = GEAR_SWEEP[int(t / HOLD_S)]
    elif (t := t - HOLD_S * len(GEAR_SWEEP)) >= 0.0:
        step = min(int(t / HOLD_S), 3)
        light = "low_beam" if step < 2 else "hazard"
        if step % 2 == 0:
            lights[light] = 1 - lights[light]
    channels = [CENTRE_RAW] * ibus.CHANNEL_COUNT
    for axis, norm in ((mapping.steering, steering), (mapping.throttle_brake, pedal)):
        channels[axis.channel] = round(CENTRE_RAW + FULL_TRAVEL_RAW * travel * norm)
    switches = (
        (mapping.mode_switch, mode),
        (mapping.gear_switch, gear),
        (mapping.low_beam_switch, lights["low_beam"]),
        (mapping.hazard_switch, lights["hazard"]),
    )
    for switch, physical in switches:
        channels[switch.channel] = switch_raw(physical, len(switch.positions_raw), travel)
    return tuple(channels)


class SweepSource:
    """The simulated receiver's bytes (a `ByteSource`), the transmitter moved by the sweep.

    `paced`: the virtual clock follows the wall clock (the live view); otherwise `wait` runs
    the simulation that long at once (a snapshot)."""

    def __init__(self, mapping: RcMapping, travel: float, *, paced: bool, seed: int = 0) -> None:
        self.name = f"simulated transmitter (sweep at {travel:.0%} travel)"
        self._mapping, self._travel, self._paced = mapping, travel, paced
        self._clock = VirtualClock()
        self._uart = SimUart(self._clock)
        self._random = random.Random(seed)
        self._transmitter = SimRcTransmitter(
            self._clock, self._uart, mapping=mapping, channels=self._channels(0.0)
        )
        self._mover = PeriodicTimer(self._clock, ibus.FRAME_PERIOD_S, self._move)
        self._mover.start(0.0)
        self._transmitter.start(MOVE_LEAD_S)
        self._wall_start_s = time.monotonic()

    def _channels(self, t_s: float) -> Sequence[int]:
        channels = list(sweep_channels(t_s, self._mapping, self._travel))
        for axis in (self._mapping.steering, self._mapping.throttle_brake):
            channels[axis.channel] += self._random.randint(-JITTER_RAW, JITTER_RAW)
        return channels

    def _move(self, tick_s: float) -> None:
        self._transmitter.set_channels(dict(enumerate(self._channels(tick_s + MOVE_LEAD_S))))

    def read(self) -> bytes:
        if self._paced:
            self._clock.advance(max(time.monotonic() - self._wall_start_s - self.now(), 0.0))
        return self._uart.read_available()

    def now(self) -> float:
        return self._clock.now()

    def wait(self, duration_s: float) -> None:
        if self._paced:
            time.sleep(duration_s)
        else:
            self._clock.advance(duration_s)

    @property
    def problem(self) -> str | None:
        return None

    def close(self) -> None:
        self._transmitter.stop()
        self._mover.stop()
