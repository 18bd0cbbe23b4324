"""The simulated operator of `bywire rc --sim`: real IBUS bytes from the simulated receiver, every
stick to both ends and every switch through its positions in one sweep."""

from __future__ import annotations

from dataclasses import replace

import pytest

from bywire.config import RobotConfig
from bywire.control.rc_mapping import RcMapping, switch_position
from bywire.hal.simulated.rc_transmitter import idle_channels
from bywire.protocol import ibus
from bywire.rc.ibus_reading import RcSession
from bywire.rc.suggestion import SwitchSuggestion
from bywire.rc.sweep import JITTER_RAW, SWEEP_S, SweepSource, sweep_channels

MAPPING = RcMapping()


def _sampled(mapping: RcMapping, travel: float) -> list[tuple[int, ...]]:
    return [sweep_channels(k * 0.005, mapping, travel) for k in range(int(SWEEP_S / 0.005))]


def test_at_full_travel_the_sweep_starts_as_the_simulators_transmitter_at_rest() -> None:
    assert sweep_channels(0.0, MAPPING, 1.0) == idle_channels(MAPPING)


@pytest.mark.parametrize("travel", [1.0, 0.5])
def test_one_sweep_takes_every_stick_to_both_ends_and_every_switch_through_its_positions(
    travel: float,
) -> None:
    frames = _sampled(MAPPING, travel)
    span = round(500 * travel)
    for axis in (MAPPING.steering, MAPPING.throttle_brake):
        pulses = {frame[axis.channel] for frame in frames}
        assert (min(pulses), max(pulses)) == (1500 - span, 1500 + span)
    for switch in (MAPPING.mode_switch, MAPPING.gear_switch):
        assert {frame[switch.channel] for frame in frames} == {1500 - span, 1500, 1500 + span}
    for switch in (MAPPING.low_beam_switch, MAPPING.hazard_switch):
        assert {frame[switch.channel] for frame in frames} == {1500 - span, 1500 + span}


def test_the_sweep_rests_where_the_robot_file_reads_stop_even_on_a_reversed_switch() -> None:
    reversed_mode = replace(MAPPING.mode_switch, reverse=True)
    mapping = replace(MAPPING, mode_switch=reversed_mode)
    raw = sweep_channels(0.0, mapping, 1.0)[reversed_mode.channel]
    assert raw == 2000
    assert mapping.mode_positions[switch_position(raw, reversed_mode) or 0].name == "STOP"


def test_a_whole_sweep_in_virtual_time_is_every_frame_of_a_real_receiver() -> None:
    source = SweepSource(MAPPING, 1.0, paced=False)
    session = RcSession(RobotConfig())
    source.wait(SWEEP_S)
    session.feed(source.read(), source.now())
    stats = session.parser.stats
    assert stats.frames == pytest.approx(SWEEP_S / ibus.FRAME_PERIOD_S, abs=1)
    assert stats.checksum_errors == 0
    assert session.suggestion().refusals == ()
    suggested = session.suggestion().mapping(MAPPING)
    for name in ("mode_switch", "gear_switch", "low_beam_switch", "hazard_switch"):
        assert getattr(suggested, name) == getattr(MAPPING, name)  # 100 %: the defaults
    for axis in (suggested.steering, suggested.throttle_brake):
        ends = (axis.min_raw, axis.center_raw, axis.max_raw)
        assert ends == pytest.approx((1000, 1500, 2000), abs=JITTER_RAW + 8)  # a frame's step


def test_a_half_travel_transmitter_gets_half_travel_positions() -> None:
    source = SweepSource(MAPPING, 0.5, paced=False)
    session = RcSession(RobotConfig())
    source.wait(SWEEP_S)
    session.feed(source.read(), source.now())
    item = session.suggestion().item("mode_switch")
    assert isinstance(item, SwitchSuggestion)
    assert item.positions_raw == (1250, 1500, 1750)
