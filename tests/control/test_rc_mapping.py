"""RC mapping: Table 3 defaults, calibration, deadband, reverse, implausible channels."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.control.rc_mapping import (
    PLAUSIBLE_RAW,
    AxisCalibration,
    FailsafeSignature,
    RcMapping,
    RcStage,
    SwitchCalibration,
    SwitchesHeld,
    axis_norm,
    channels_plausible,
    in_failsafe,
    mode_position,
    rc_request,
    rc_step,
    switch_position,
)
from bywire.model import ControlMode, Gear

STOP, RC, CAN = ControlMode.STOP, ControlMode.RC, ControlMode.CAN

CENTRED = (1500,) * 14


def frame(**channels: int) -> tuple[int, ...]:
    """Table 3 frame with the named channels set (ch0…ch13)."""
    values = list(CENTRED)
    for name, raw in channels.items():
        values[int(name.removeprefix("ch"))] = raw
    return tuple(values)


@pytest.mark.parametrize(
    ("raw", "norm"),
    [(1000, -1.0), (1250, -0.5), (1500, 0.0), (1505, 0.0), (1750, 0.5), (2000, 1.0), (2100, 1.0)],
)
def test_axis_normalisation_with_deadband(raw: int, norm: float) -> None:
    assert axis_norm(raw, AxisCalibration(channel=0)) == pytest.approx(norm)


def test_axis_calibration_and_reverse() -> None:
    calibration = AxisCalibration(
        channel=0, min_raw=1100, center_raw=1520, max_raw=1900, reverse=True
    )
    assert axis_norm(1900, calibration) == pytest.approx(-1.0)
    assert axis_norm(1100, calibration) == pytest.approx(1.0)
    assert axis_norm(1520, calibration) == 0.0


@pytest.mark.parametrize(
    ("raw", "position"),
    [(850, 0), (1000, 0), (1150, 0), (1350, 1), (1500, 1), (1650, 1), (2150, 2)],
)
def test_switch_positions(raw: int, position: int) -> None:
    assert switch_position(raw, SwitchCalibration(channel=6)) == position
    assert switch_position(raw, SwitchCalibration(channel=6, reverse=True)) == 2 - position


def test_table_3_defaults_map_sticks_and_switches() -> None:
    request = rc_request(
        frame(ch0=1750, ch1=1750, ch5=2000, ch6=2000, ch7=2000, ch8=1000), RcMapping()
    )
    assert request is not None
    assert request.steering_norm == pytest.approx(0.5)
    assert request.throttle_norm == pytest.approx(0.5)
    assert request.brake_norm == 0.0
    assert request.mode is ControlMode.CAN
    assert request.gear is Gear.FORWARD
    assert request.low_beam
    assert not request.hazard


def test_left_stick_below_centre_is_brake_and_never_throttle() -> None:
    request = rc_request(frame(ch1=1000, ch6=1500, ch7=1000), RcMapping())
    assert request is not None
    assert request.throttle_norm == 0.0
    assert request.brake_norm == pytest.approx(1.0)
    assert request.mode is ControlMode.RC
    assert request.gear is Gear.REVERSE


def test_mode_switch_low_is_stop() -> None:
    request = rc_request(frame(ch6=1000), RcMapping())
    assert request is not None
    assert request.mode is ControlMode.STOP


@pytest.mark.parametrize("channel", [0, 1, 5, 6, 7, 8])
@pytest.mark.parametrize("raw", [0, 799, 2201, 0xFFFF, 0x85DC])
def test_an_implausible_used_channel_rejects_the_whole_frame(channel: int, raw: int) -> None:
    assert rc_request(frame(**{f"ch{channel}": raw}), RcMapping()) is None


def test_unused_channels_do_not_matter() -> None:
    assert rc_request(frame(ch13=0xFFFF), RcMapping()) is not None


@given(st.tuples(*[st.integers(0, 0xFFFF)] * 14))
def test_any_frame_maps_into_command_ranges_or_is_rejected(channels: tuple[int, ...]) -> None:
    request = rc_request(channels, RcMapping())
    if request is not None:
        assert -1.0 <= request.steering_norm <= 1.0
        assert 0.0 <= request.throttle_norm <= 1.0
        assert 0.0 <= request.brake_norm <= 1.0
        assert request.throttle_norm == 0.0 or request.brake_norm == 0.0


def test_failsafe_signature_refuses_the_frame_at_once() -> None:
    mapping = RcMapping()
    assert rc_request(frame(ch1=900), mapping) is None
    assert rc_request(frame(ch1=949), mapping) is None
    assert rc_request(frame(ch1=950), mapping) is not None  # boundary: not below
    assert rc_request(frame(ch1=1000), mapping) is not None


def test_failsafe_signature_channel_is_configurable() -> None:
    mapping = RcMapping(failsafe=FailsafeSignature(channel=9, below_raw=1100))
    assert rc_request(frame(ch9=1000), mapping) is None
    assert rc_request(frame(ch1=900), mapping) is not None  # 900 is a plausible stick value


# Tests added after mutation testing (docs/mutation.md). RC mapping at its exact edges: deadband,
# end stops, switch thresholds, short frames, hazard.


def test_a_stick_exactly_at_the_deadband_edge_is_outside_the_deadband() -> None:
    # 10 µs of a 500 µs half-range is exactly the default deadband of 0.02
    assert axis_norm(1510, AxisCalibration(channel=0)) == 0.02
    assert axis_norm(1509, AxisCalibration(channel=0)) == 0.0


@pytest.mark.parametrize(("raw", "norm"), [(800, -1.0), (900, -1.0), (2200, 1.0)])
def test_a_stick_beyond_its_calibrated_end_stops_is_clamped_to_full_scale(
    raw: int, norm: float
) -> None:
    assert axis_norm(raw, AxisCalibration(channel=1)) == norm


@pytest.mark.parametrize("raw", [1151, 1250, 1349, 1651, 1750, 1849, 800, 2200])
def test_a_value_between_positions_is_no_position(raw: int) -> None:
    # Issue 30, finding 3: a transmitter with 50 % switch travel sends 1250 µs at STOP, and the
    # bare thresholds read it as RC: the robot kept driving at 2.5 V.
    assert switch_position(raw, SwitchCalibration(channel=6)) is None


def test_a_position_read_holds_within_its_hysteresis_and_not_beyond() -> None:
    switch = SwitchCalibration(channel=6)
    assert switch_position(1660, switch) is None  # outside RC's band, read afresh
    assert switch_position(1660, switch, held=1) == 1  # held: within band + hysteresis
    assert switch_position(1675, switch, held=1) == 1
    assert switch_position(1676, switch, held=1) is None


def test_a_50_percent_switch_at_stop_is_stop_never_rc() -> None:
    request = rc_request(frame(ch6=1250), RcMapping())
    assert request is not None
    assert request.mode is ControlMode.STOP


@given(st.integers(800, 2200), st.sampled_from([None, 0, 1, 2]))
def test_no_value_reads_as_a_position_outside_its_band_and_hysteresis(
    raw: int, held: int | None
) -> None:
    switch = SwitchCalibration(channel=6)
    position = switch_position(raw, switch, held)
    if position is not None:
        low, high = switch.band(position)
        reach = switch.hysteresis_raw if position == held else 0
        assert low - reach <= raw <= high + reach


def test_a_frame_too_short_for_the_used_channels_is_implausible_not_a_crash() -> None:
    mapping = RcMapping()
    short = CENTRED[:8]  # the hazard switch is channel 8
    assert not channels_plausible(short, mapping)
    assert rc_request(short, mapping) is None


def test_a_frame_too_short_for_the_failsafe_channel_is_not_failsafe_output() -> None:
    mapping = RcMapping()
    assert not in_failsafe(CENTRED[:1], mapping)
    assert rc_request(CENTRED[:1], mapping) is None  # and still refused: too short to use


def test_the_hazard_switch_up_asks_for_hazard_lights() -> None:
    channels = (*CENTRED[:8], 2000, *CENTRED[9:])
    request = rc_request(channels, RcMapping())
    assert request is not None
    assert request.hazard
    assert not request.low_beam


# --- the mode switch's transit (issue 41, finding 10), checked exhaustively --------------------

TRANSIT_SWITCHES = [
    (SwitchCalibration(channel=6), (STOP, RC, CAN)),
    (SwitchCalibration(channel=6, reverse=True), (STOP, RC, CAN)),
    (
        SwitchCalibration(6, positions_raw=(1250, 1500, 1750), band_raw=100, hysteresis_raw=16),
        (STOP, RC, CAN),
    ),
    (SwitchCalibration(channel=6), (CAN, RC, STOP)),
    (SwitchCalibration(channel=6), (RC, STOP, CAN)),  # STOP in the middle: no transit to hold
]


def _within(raw: int, switch: SwitchCalibration, position: int, reach: int) -> bool:
    nominal = switch.positions_raw[switch.logical(position)]
    return abs(raw - nominal) <= switch.band_raw + reach


def _around(raw: int, switch: SwitchCalibration) -> tuple[int, int] | None:
    """The positions whose nominal pulses are the nearest below and above `raw` (logical)."""
    below = [i for i, p in enumerate(switch.positions_raw) if p < raw]
    above = [i for i, p in enumerate(switch.positions_raw) if p > raw]
    if not below or not above:
        return None
    return switch.logical(max(below)), switch.logical(min(above))


def _transit_violations(
    switch: SwitchCalibration, modes: tuple[ControlMode, ...], hold: int
) -> list[str]:
    mapping = RcMapping(mode_switch=switch, mode_positions=modes)  # type: ignore[arg-type]
    positions = range(len(switch.positions_raw))
    found = []
    for raw in PLAUSIBLE_RAW:
        in_band = [p for p in positions if _within(raw, switch, p, 0)]
        around = _around(raw, switch)
        for held in (None, *positions):
            for transit in range(hold + 1):
                got, transit_after = mode_position(raw, mapping, held, transit, hold)
                kept = held is not None and _within(raw, switch, held, switch.hysteresis_raw)
                where = f"raw {raw}, held {held}, {transit} frames in transit"
                if in_band or kept:  # a position read: as before, nothing in transit
                    if (got, transit_after) != (switch_position(raw, switch, held), 0):
                        found.append(f"T1 a position read as before: {where}")
                    continue
                stop_next = around is None or STOP in (modes[around[0]], modes[around[1]])
                if stop_next and got is not None:  # beside STOP, or beyond the ends
                    found.append(f"T2 beside STOP is STOP at once: {where}")
                elif not stop_next and around is not None:
                    holds = held in around and transit < hold
                    wanted = (held, transit + 1) if holds else (None, 0)
                    if (got, transit_after) != wanted:
                        found.append(f"T3 between driving positions, held {hold} frames: {where}")
    return found


@pytest.mark.parametrize("hold", [2, 3, 5])
@pytest.mark.parametrize(("switch", "modes"), TRANSIT_SWITCHES)
def test_every_value_after_every_position_and_time_in_transit_keeps_the_transit_rule(
    switch: SwitchCalibration, modes: tuple[ControlMode, ...], hold: int
) -> None:
    assert _transit_violations(switch, modes, hold) == []


@pytest.mark.parametrize(("switch", "modes"), TRANSIT_SWITCHES[:4])
def test_a_value_held_between_two_driving_positions_is_stop_after_the_debounce(
    switch: SwitchCalibration, modes: tuple[ControlMode, ...]
) -> None:
    # Issue 41, finding 10: RC to CAN with one frame at 1700 µs read STOP: the spring brake at
    # 0.84 m/s. Now the frames in transit hold the position read before, for the debounce.
    mapping = RcMapping(mode_switch=switch, mode_positions=modes)  # type: ignore[arg-type]
    low, high = (modes.index(RC), modes.index(CAN))
    between = (
        switch.positions_raw[switch.logical(low)] + switch.positions_raw[switch.logical(high)]
    ) // 2
    for held in (low, high):
        stage, shown = RcStage(held=SwitchesHeld(mode=held)), []
        channels = list(frame(ch6=between))
        for _ in range(6):
            stage, request = rc_step(stage, tuple(channels), mapping, 3)
            assert request is not None
            shown.append(request.mode)
        assert shown == [modes[held]] * 3 + [STOP] * 3
