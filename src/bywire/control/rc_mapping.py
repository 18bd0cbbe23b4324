"""RC mapping: raw IBUS channels to a movement request, with per-channel calibration (R-RCMAP).

Defaults follow Table 3 of the thesis: right stick horizontal (channel 0) steers, left stick
vertical (channel 1) is throttle above centre and brake below, the two 3-position switches choose
the control mode (channel 6) and the gear (channel 7), the 2-position switches give low beam
(channel 5) and hazard (channel 8). Values outside the plausible pulse range make the whole frame
suspect: the caller treats that like a lost link, at once.
"""

from __future__ import annotations

from dataclasses import field

from bywire.control.values import value
from bywire.model import ControlMode, Gear

PLAUSIBLE_RAW = range(800, 2201)  # µs; anything else is a corrupt or failsafe-flagged channel


@value
class AxisCalibration:
    """One stick axis: channel index, raw end points and centre, deadband (normalised), reverse."""

    channel: int
    min_raw: int = 1000
    center_raw: int = 1500
    max_raw: int = 2000
    deadband_norm: float = 0.02
    reverse: bool = False


@value
class SwitchCalibration:
    """One switch: channel index and whether its positions run the other way."""

    channel: int
    reverse: bool = False


@value
class FailsafeSignature:
    """How to recognise the receiver's failsafe output (R-FAILSAFE, Table 4).

    On losing the transmitter a FlySky receiver sends the failsafe values set on the transmitter.
    Set the failsafe of `channel` to a pulse below `below_raw` (e.g. 900 µs on the throttle stick,
    a value the stick itself never reaches) and bywire recognises failsafe frames at once.
    """

    channel: int = 1
    below_raw: int = 950


@value
class RcMapping:
    """Which channel does what; the modes and gears are listed from the low to the high position."""

    steering: AxisCalibration = field(default_factory=lambda: AxisCalibration(channel=0))
    throttle_brake: AxisCalibration = field(default_factory=lambda: AxisCalibration(channel=1))
    mode_switch: SwitchCalibration = field(default_factory=lambda: SwitchCalibration(channel=6))
    gear_switch: SwitchCalibration = field(default_factory=lambda: SwitchCalibration(channel=7))
    low_beam_switch: SwitchCalibration = field(default_factory=lambda: SwitchCalibration(5))
    hazard_switch: SwitchCalibration = field(default_factory=lambda: SwitchCalibration(8))
    mode_positions: tuple[ControlMode, ControlMode, ControlMode] = (
        ControlMode.STOP,
        ControlMode.RC,
        ControlMode.CAN,
    )
    gear_positions: tuple[Gear, Gear, Gear] = (Gear.REVERSE, Gear.NEUTRAL, Gear.FORWARD)
    failsafe: FailsafeSignature = field(default_factory=FailsafeSignature)


@value
class RcRequest:
    """What the RC transmitter asks for, in command units."""

    mode: ControlMode
    steering_norm: float
    throttle_norm: float
    brake_norm: float
    gear: Gear
    low_beam: bool
    hazard: bool


def axis_norm(raw: int, calibration: AxisCalibration) -> float:
    """Raw pulse to −1…1 around the calibrated centre, zero inside the deadband."""
    if raw >= calibration.center_raw:
        norm = (raw - calibration.center_raw) / (calibration.max_raw - calibration.center_raw)
    else:
        norm = (raw - calibration.center_raw) / (calibration.center_raw - calibration.min_raw)
    norm = -norm if calibration.reverse else norm
    return 0.0 if abs(norm) < calibration.deadband_norm else min(max(norm, -1.0), 1.0)


def switch_position(raw: int, calibration: SwitchCalibration) -> int:
    """0, 1 or 2 for low, middle, high (a 2-position switch gives 0 or 2)."""
    position = 0 if raw < 1250 else (1 if raw <= 1750 else 2)
    return 2 - position if calibration.reverse else position


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


def rc_request(channels: tuple[int, ...], mapping: RcMapping) -> RcRequest | None:
    """The request this frame carries, or None when it is failsafe output or any used channel is
    implausible: suspect input is refused whole, at once."""
    if in_failsafe(channels, mapping) or not channels_plausible(channels, mapping):
        return None

    def position(switch: SwitchCalibration) -> int:
        return switch_position(channels[switch.channel], switch)

    pedal_norm = axis_norm(channels[mapping.throttle_brake.channel], mapping.throttle_brake)
    return RcRequest(
        mode=mapping.mode_positions[position(mapping.mode_switch)],
        steering_norm=axis_norm(channels[mapping.steering.channel], mapping.steering),
        throttle_norm=max(pedal_norm, 0.0),
        brake_norm=max(-pedal_norm, 0.0),
        gear=mapping.gear_positions[position(mapping.gear_switch)],
        low_beam=position(mapping.low_beam_switch) == 2,
        hazard=position(mapping.hazard_switch) == 2,
    )
