"""RC mapping: raw IBUS channels to a movement request, with per-channel calibration (R-RCMAP).

Defaults follow Table 3 of the thesis: right stick horizontal (channel 0) steers, left stick
vertical (channel 1) is throttle above centre and brake below, the two 3-position switches choose
the control mode (channel 6) and the gear (channel 7), the 2-position switches give low beam
(channel 5) and hazard (channel 8). Values outside the plausible pulse range make the whole frame
suspect: the caller treats that like a lost link, at once.

Switches are decoded by calibrated bands with hysteresis (R-SWITCH): each position has a nominal
pulse and a band around it; a value in no band is *no position* (the mode switch then means
STOP, the gear switch neutral, a light off); a position, once read, holds until the value leaves
its band widened by the hysteresis, so a knob dithering at a band's edge does not flip it. A
transmitter whose switch travel is set to 50 % sends 1250 µs in its low position: read with the
default bands that is no position (STOP), never RC. `bywire rc` shows what a transmitter sends
and suggests the bands.

The mode switch's transit (R-SWITCH, issue 41): a value between two neighbouring positions
neither of which is STOP (RC and CAN on the default switch) is a switch moving between them, not
a STOP request: it holds the position read before (one of the two) for at most
`debounce_frames` frames in a row, the supervisor's debounce, then reads as no position (STOP).
A value between STOP and a neighbour is STOP at once, as before. Which positions neighbour STOP
comes from the calibration (`positions_raw`, `reverse`) and `mode_positions`, not from fixed
pulses (`mode_position`). Before, one IBUS frame caught at 1700 µs in an RC to CAN handover at
0.84 m/s was STOP: the spring brake at speed, and CAN arming then refused with the switch at CAN.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from bywire.control.values import slot_init
from bywire.model import ControlMode, Gear

PLAUSIBLE_RAW = range(800, 2201)  # µs; anything else is a corrupt or failsafe-flagged channel


@dataclass(frozen=True, slots=True)
class AxisCalibration:
    """One stick axis: channel index, raw end points and centre, deadband (normalised), reverse."""

    channel: int
    min_raw: int = 1000
    center_raw: int = 1500
    max_raw: int = 2000
    deadband_norm: float = 0.02
    reverse: bool = False


THREE_POSITIONS_RAW = (1000, 1500, 2000)
TWO_POSITIONS_RAW = (1000, 2000)


@dataclass(frozen=True, slots=True)
class SwitchCalibration:
    """One switch: channel index, the nominal pulse of each position (low to high), the band
    around each (± `band_raw` µs), the hysteresis that holds a position read at a band's edge,
    and whether its positions run the other way."""

    channel: int
    reverse: bool = False
    positions_raw: tuple[int, ...] = THREE_POSITIONS_RAW
    band_raw: int = 150
    hysteresis_raw: int = 25

    def band(self, index: int) -> tuple[int, int]:
        """The raw range (µs, inclusive) of the position `index` (counted low to high)."""
        nominal = self.positions_raw[index]
        return nominal - self.band_raw, nominal + self.band_raw

    def logical(self, index: int) -> int:
        """The position (as the switch's users count them) of the `index`-th pulse from low."""
        return len(self.positions_raw) - 1 - index if self.reverse else index


@dataclass(frozen=True, slots=True)
class FailsafeSignature:
    """How to recognise the receiver's failsafe output (R-FAILSAFE, Table 4).

    On losing the transmitter a FlySky receiver sends the failsafe values set on the transmitter.
    Set the failsafe of `channel` to a pulse below `below_raw` (e.g. 900 µs on the throttle stick,
    a value the stick itself never reaches) and bywire recognises failsafe frames at once.
    """

    channel: int = 1
    below_raw: int = 950


@dataclass(frozen=True, slots=True)
class RcMapping:
    """Which channel does what; the modes and gears are listed from the low to the high position."""

    steering: AxisCalibration = field(default_factory=lambda: AxisCalibration(channel=0))
    throttle_brake: AxisCalibration = field(default_factory=lambda: AxisCalibration(channel=1))
    mode_switch: SwitchCalibration = field(default_factory=lambda: SwitchCalibration(channel=6))
    gear_switch: SwitchCalibration = field(default_factory=lambda: SwitchCalibration(channel=7))
    low_beam_switch: SwitchCalibration = field(
        default_factory=lambda: SwitchCalibration(5, positions_raw=TWO_POSITIONS_RAW)
    )
    hazard_switch: SwitchCalibration = field(
        default_factory=lambda: SwitchCalibration(8, positions_raw=TWO_POSITIONS_RAW)
    )
    mode_positions: tuple[ControlMode, ControlMode, ControlMode] = (
        ControlMode.STOP,
        ControlMode.RC,
        ControlMode.CAN,
    )
    gear_positions: tuple[Gear, Gear, Gear] = (Gear.REVERSE, Gear.NEUTRAL, Gear.FORWARD)
    failsafe: FailsafeSignature = field(default_factory=FailsafeSignature)


@dataclass(frozen=True, slots=True)
class RcRequest:
    """What the RC transmitter asks for, in command units. `mode_between`: the mode switch lies
    between positions (or beyond the end ones), so `mode` is STOP, at once, but the switch is
    not at the STOP position: such frames are no stay at STOP, and ready no arming
    (`supervisor._debounced`)."""

    mode: ControlMode
    steering_norm: float
    throttle_norm: float
    brake_norm: float
    gear: Gear
    low_beam: bool
    hazard: bool
    mode_between: bool = False

    def __init__(  # noqa: PLR0917
        self,
        mode: ControlMode,
        steering_norm: float,
        throttle_norm: float,
        brake_norm: float,
        gear: Gear,
        low_beam: bool,
        hazard: bool,
        mode_between: bool = False,
    ) -> None:
        object.__setattr__(self, "mode", mode)
        object.__setattr__(self, "steering_norm", steering_norm)
        object.__setattr__(self, "throttle_norm", throttle_norm)
        object.__setattr__(self, "brake_norm", brake_norm)
        object.__setattr__(self, "gear", gear)
        object.__setattr__(self, "low_beam", low_beam)
        object.__setattr__(self, "hazard", hazard)
        object.__setattr__(self, "mode_between", mode_between)


slot_init(RcRequest)


def axis_norm(raw: int, calibration: AxisCalibration) -> float:
    """Raw pulse to −1…1 around the calibrated centre, zero inside the deadband."""
    if raw >= calibration.center_raw:
        norm = (raw - calibration.center_raw) / (calibration.max_raw - calibration.center_raw)
    else:
        norm = (raw - calibration.center_raw) / (calibration.center_raw - calibration.min_raw)
    norm = -norm if calibration.reverse else norm
    return 0.0 if abs(norm) < calibration.deadband_norm else min(max(norm, -1.0), 1.0)


def switch_position(
    raw: int, calibration: SwitchCalibration, held: int | None = None
) -> int | None:
    """The position (0 for the first of the switch's positions, reversed if asked) whose band
    holds `raw`; `held`, the position read before, while `raw` stays within its band widened
    by the hysteresis; None between positions."""
    count = len(calibration.positions_raw)
    if held is not None and 0 <= held < count:
        low, high = calibration.band(calibration.logical(held))
        if low - calibration.hysteresis_raw <= raw <= high + calibration.hysteresis_raw:
            return held
    for index in range(count):
        low, high = calibration.band(index)
        if low <= raw <= high:
            return calibration.logical(index)
    return None


def neighbours_around(raw: int, calibration: SwitchCalibration) -> tuple[int, int] | None:
    """The two neighbouring positions whose bands `raw` lies between; None inside a band or
    beyond the end ones."""
    for index in range(len(calibration.positions_raw) - 1):
        if calibration.band(index)[1] < raw < calibration.band(index + 1)[0]:
            return calibration.logical(index), calibration.logical(index + 1)
    return None


def mode_position(
    raw: int, mapping: RcMapping, held: int | None, transit_frames: int, hold_frames: int
) -> tuple[int | None, int]:
    """The mode switch's position this frame and how many frames in a row it has now been
    held in transit: `switch_position` with the hysteresis; between two neighbours neither of
    which is STOP, with `held` one of them, `held` again for at most `hold_frames` frames in a
    row; anything else between positions is no position (STOP) at once."""
    switch = mapping.mode_switch
    position = switch_position(raw, switch, held)
    if position is not None or held is None:
        return position, 0
    pair = neighbours_around(raw, switch)
    if pair is None or held not in pair or transit_frames >= hold_frames:
        return None, 0
    modes = mapping.mode_positions
    if any(index >= len(modes) or modes[index] is ControlMode.STOP for index in pair):
        return None, 0
    return held, transit_frames + 1


def channels_plausible(channels: tuple[int, ...], mapping: RcMapping) -> bool:
    """True when every channel the mapping uses holds a plausible pulse width."""
    used = (
        mapping.steering.channel,
        mapping.throttle_brake.channel,
        mapping.mode_switch.channel,
        mapping.gear_switch.channel,
        mapping.low_beam_switch.channel,
        mapping.hazard_switch.channel,
    )
    return all(index < len(channels) and channels[index] in PLAUSIBLE_RAW for index in used)


def in_failsafe(channels: tuple[int, ...], mapping: RcMapping) -> bool:
    """True when the frame carries the receiver's failsafe signature."""
    signature = mapping.failsafe
    return signature.channel < len(channels) and channels[signature.channel] < signature.below_raw


@dataclass(frozen=True, slots=True)
class SwitchesHeld:
    """Each switch's position as last read (None: between positions, or not read yet): what the
    hysteresis holds, and the frames in a row the mode switch's has been held in transit. The
    mode switch's debounce is the supervisor's; the gear's is `gear`."""

    mode: int | None = None
    gear: int | None = None
    low_beam: int | None = None
    hazard: int | None = None
    mode_transit: int = 0

    def __init__(
        self,
        mode: int | None = None,
        gear: int | None = None,
        low_beam: int | None = None,
        hazard: int | None = None,
        mode_transit: int = 0,
    ) -> None:
        object.__setattr__(self, "mode", mode)
        object.__setattr__(self, "gear", gear)
        object.__setattr__(self, "low_beam", low_beam)
        object.__setattr__(self, "hazard", hazard)
        object.__setattr__(self, "mode_transit", mode_transit)


slot_init(SwitchesHeld)


NONE_HELD = SwitchesHeld()


def rc_request(channels: tuple[int, ...], mapping: RcMapping) -> RcRequest | None:
    """The request one frame carries on its own (no position held before it), or None when it
    is failsafe output or any used channel is implausible: suspect input is refused whole."""
    return rc_decoded(channels, mapping, NONE_HELD)[0]


def rc_decoded(
    channels: tuple[int, ...], mapping: RcMapping, held: SwitchesHeld, transit_frames: int = 0
) -> tuple[RcRequest | None, SwitchesHeld]:
    """The request this frame carries, and the switches' positions now (the mode switch held
    in transit for at most `transit_frames` frames: `mode_position`); the request is None
    when the frame is failsafe output or any used channel is implausible: suspect input is
    refused whole, at once (and the positions held are forgotten)."""
    if in_failsafe(channels, mapping) or not channels_plausible(channels, mapping):
        return None, NONE_HELD
    mode, transit = mode_position(
        channels[mapping.mode_switch.channel], mapping, held.mode, held.mode_transit, transit_frames
    )
    positions = SwitchesHeld(
        mode=mode,
        mode_transit=transit,
        gear=switch_position(channels[mapping.gear_switch.channel], mapping.gear_switch, held.gear),
        low_beam=switch_position(
            channels[mapping.low_beam_switch.channel], mapping.low_beam_switch, held.low_beam
        ),
        hazard=switch_position(
            channels[mapping.hazard_switch.channel], mapping.hazard_switch, held.hazard
        ),
    )
    pedal_norm = axis_norm(channels[mapping.throttle_brake.channel], mapping.throttle_brake)
    request = RcRequest(
        mode=ControlMode.STOP if positions.mode is None else mapping.mode_positions[positions.mode],
        steering_norm=axis_norm(channels[mapping.steering.channel], mapping.steering),
        throttle_norm=max(pedal_norm, 0.0),
        brake_norm=max(-pedal_norm, 0.0),
        gear=Gear.NEUTRAL if positions.gear is None else mapping.gear_positions[positions.gear],
        low_beam=_on(positions.low_beam, mapping.low_beam_switch),
        hazard=_on(positions.hazard, mapping.hazard_switch),
        mode_between=positions.mode is None,
    )
    return request, positions


def _on(position: int | None, switch: SwitchCalibration) -> bool:
    """A light switch is on in its last (highest) position."""
    return position == len(switch.positions_raw) - 1


@dataclass(frozen=True, slots=True)
class RcStage:
    """The RC frames' state between frames: the switches' positions as last read (the
    hysteresis) and the gear as debounced: a new gear counts once `debounce_frames` frames in a
    row showed it (the mode switch's debounce is the supervisor's); a gear switch between
    positions is neutral at once, the safe direction. The mode switch in transit between two
    driving positions holds for at most `debounce_frames` frames (`mode_position`)."""

    held: SwitchesHeld = NONE_HELD
    gear: Gear = Gear.NEUTRAL
    candidate: Gear = Gear.NEUTRAL
    run: int = 0

    def __init__(
        self,
        held: SwitchesHeld = NONE_HELD,
        gear: Gear = Gear.NEUTRAL,
        candidate: Gear = Gear.NEUTRAL,
        run: int = 0,
    ) -> None:
        object.__setattr__(self, "held", held)
        object.__setattr__(self, "gear", gear)
        object.__setattr__(self, "candidate", candidate)
        object.__setattr__(self, "run", run)


slot_init(RcStage)


def rc_step(
    stage: RcStage, channels: tuple[int, ...], mapping: RcMapping, debounce_frames: int
) -> tuple[RcStage, RcRequest | None]:
    """One frame: the next stage and the request it carries (None: refused whole)."""
    request, held = rc_decoded(channels, mapping, stage.held, debounce_frames)
    if request is None:
        return RcStage(gear=stage.gear), None
    shown = request.gear
    run = min(stage.run + 1, debounce_frames) if shown is stage.candidate else 1
    if held.gear is None or shown is Gear.NEUTRAL or run >= debounce_frames:
        gear = shown
    else:
        gear = stage.gear
    new_stage = RcStage(held, gear, shown, run)
    return new_stage, request if request.gear is gear else replace(request, gear=gear)
