"""Simulated RC transmitter: real IBUS frames every period, named controls, and the link faults."""

from __future__ import annotations

import itertools
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.control.rc_mapping import (
    AxisCalibration,
    RcMapping,
    SwitchCalibration,
    axis_norm,
    rc_request,
)
from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.rc_transmitter import (
    SimRcTransmitter,
    idle_channels,
    raw_for_axis,
    raw_for_switch,
)
from bywire.hal.simulated.uart import SimUart
from bywire.model import ControlMode, Gear
from bywire.protocol import ibus

FRAME_S = 32 * 10 / 115_200


def running_transmitter(
    *, mapping: RcMapping | None = None, seed: int = 0
) -> tuple[VirtualClock, SimUart, SimRcTransmitter]:
    clock = VirtualClock()
    uart = SimUart(clock)
    rc = SimRcTransmitter(clock, uart, mapping=mapping, seed=seed)
    rc.start()
    return clock, uart, rc


def test_frames_arrive_every_period_and_decode() -> None:
    clock, uart, rc = running_transmitter()
    parser = ibus.IbusParser()
    completed_at: list[float] = []
    while clock.now() < 0.1:
        clock.wait_until(0.1)  # woken by the idle-line interrupt after each frame
        if parser.feed(uart.read_available(), clock.now()):
            completed_at.append(clock.now())
    assert rc.frames_sent == 13  # ticks at 0, 7.7, ..., 92.4 ms
    assert parser.stats.frames == 13
    assert parser.stats.checksum_errors == 0
    expected = [k * ibus.FRAME_PERIOD_S + FRAME_S for k in range(13)]
    assert completed_at == pytest.approx(expected)


def test_idle_transmitter_sends_table_3_rest_position() -> None:
    clock, uart, _ = running_transmitter()
    clock.advance(FRAME_S)
    channels = ibus.decode_frame(uart.read_available())
    assert channels == (1500,) * 5 + (1000, 1000, 1500, 1000) + (1500,) * 5
    request = rc_request(channels, RcMapping())
    assert request is not None
    assert (request.mode, request.gear, request.throttle_norm) == (
        ControlMode.STOP,
        Gear.NEUTRAL,
        0.0,
    )


def test_named_controls_produce_the_request_they_name() -> None:
    clock, uart, rc = running_transmitter()
    rc.set_mode(ControlMode.RC)
    rc.set_gear(Gear.FORWARD)
    rc.set_steering(-0.5)
    rc.set_throttle(0.8)
    rc.set_low_beam(True)
    rc.set_hazard(True)
    clock.advance(FRAME_S)
    request = rc_request(ibus.decode_frame(uart.read_available()), RcMapping())
    assert request is not None
    assert request.mode is ControlMode.RC
    assert request.gear is Gear.FORWARD
    assert request.steering_norm == pytest.approx(-0.5)
    assert request.throttle_norm == pytest.approx(0.8)
    assert request.brake_norm == 0.0
    assert request.low_beam
    assert request.hazard
    rc.set_brake(0.3)
    clock.advance(ibus.FRAME_PERIOD_S)
    request = rc_request(ibus.decode_frame(uart.read_available()), RcMapping())
    assert request is not None
    assert request.throttle_norm == 0.0
    assert request.brake_norm == pytest.approx(0.3)


def test_raw_channels_can_be_set_by_index() -> None:
    clock, uart, rc = running_transmitter()
    rc.set_channel(13, 1234)
    rc.set_channels({0: 2000, 9: 1001})
    clock.advance(FRAME_S)
    channels = ibus.decode_frame(uart.read_available())
    assert (channels[0], channels[9], channels[13]) == (2000, 1001, 1234)
    with pytest.raises(IndexError):
        rc.set_channel(14, 1500)


def test_a_reconfigured_mapping_moves_the_named_controls() -> None:
    mapping = RcMapping(
        steering=AxisCalibration(channel=3, reverse=True),
        mode_switch=SwitchCalibration(channel=9, reverse=True),
    )
    clock, uart, rc = running_transmitter(mapping=mapping)
    rc.set_steering(1.0)
    rc.set_mode(ControlMode.CAN)
    clock.advance(FRAME_S)
    channels = ibus.decode_frame(uart.read_available())
    assert (channels[3], channels[9]) == (1000, 1000)
    request = rc_request(channels, mapping)
    assert request is not None
    assert (request.steering_norm, request.mode) == (1.0, ControlMode.CAN)


@given(st.floats(-1.0, 1.0), st.booleans())
def test_raw_for_axis_inverts_axis_norm(norm: float, reverse: bool) -> None:
    calibration = AxisCalibration(channel=0, deadband_norm=0.0, reverse=reverse)
    assert axis_norm(raw_for_axis(norm, calibration), calibration) == pytest.approx(
        norm, abs=1 / 500
    )


def test_raw_for_switch_honours_reverse() -> None:
    assert [raw_for_switch(p, SwitchCalibration(0)) for p in (0, 1, 2)] == [1000, 1500, 2000]
    assert raw_for_switch(0, SwitchCalibration(0, reverse=True)) == 2000
    assert len(idle_channels(RcMapping())) == ibus.CHANNEL_COUNT


def test_link_lost_sends_no_bytes_until_restored() -> None:
    clock, uart, rc = running_transmitter()
    clock.advance(0.05)
    uart.read_available()
    sent = rc.frames_sent
    rc.link_lost()
    clock.advance(0.2)
    assert uart.read_available() == b""
    assert rc.frames_sent == sent
    rc.link_restored()
    clock.advance(0.05)
    assert len(ibus.IbusParser().feed(uart.read_available())) >= 6


def test_failsafe_values_replace_the_sticks_until_switched_off() -> None:
    clock, uart, rc = running_transmitter()
    rc.set_throttle(1.0)
    rc.set_mode(ControlMode.RC)
    rc.failsafe({1: 1500, 6: 1000})
    assert rc.in_failsafe
    clock.advance(FRAME_S)
    channels = ibus.decode_frame(uart.read_available())
    assert (channels[1], channels[6]) == (1500, 1000)
    assert rc.channels[1] == 2000  # the stick is still up; the receiver overrides it
    rc.failsafe_off()
    clock.advance(ibus.FRAME_PERIOD_S)
    channels = ibus.decode_frame(uart.read_available())
    assert (channels[1], channels[6]) == (2000, 1500)
    with pytest.raises(IndexError):
        rc.failsafe({20: 1500})


def test_corrupted_frames_fail_their_checksum_and_the_rest_decode() -> None:
    clock, uart, rc = running_transmitter(seed=7)
    rc.corrupt_next_frames(3)
    clock.advance(10 * ibus.FRAME_PERIOD_S - 0.001)
    parser = ibus.IbusParser()
    frames = parser.feed(uart.read_available())
    assert rc.corrupted_frames_sent == 3
    assert parser.stats.checksum_errors == 3
    assert len(frames) == 7


def test_corruption_is_reproducible_with_the_seed() -> None:
    streams = []
    for _ in range(2):
        clock, uart, rc = running_transmitter(seed=42)
        rc.corrupt_next_frames(5)
        clock.advance(0.05)
        streams.append(uart.read_available())
    assert streams[0] == streams[1]


LINE_RATE_S = 0.0028  # frames back to back: the shortest period a robot file allows


def _arrivals_s(clock: VirtualClock, uart: SimUart, until_s: float) -> list[float]:
    """When each whole frame's last byte arrived, reading the line every byte time."""
    parser, arrivals = ibus.IbusParser(), []
    while clock.now() < until_s:
        clock.advance(uart.byte_time_s)
        arrivals += [clock.now()] * len(parser.feed(uart.read_available()))
    return arrivals


@given(count=st.integers(1, 400), at_s=st.floats(0.0, 0.02))
def test_noise_on_the_line_loses_the_frames_it_covers_and_delays_none(
    count: int, at_s: float
) -> None:
    """Noise is no sender that the receiver waits for (docs/SAFETY.md row 80): every frame
    that arrives after the noise arrives when it would have without it, and the frames lost
    are only those due while the noise was on the line."""
    clock = VirtualClock()
    uart = SimUart(clock)
    rc = SimRcTransmitter(clock, uart, LINE_RATE_S)
    rc.start()
    clock.advance(at_s)
    rc.inject_bytes(bytes(count))  # zeros: never a header, so the parser loses no frame to it
    noise_until_s = uart.line_free_at_s
    arrivals = _arrivals_s(clock, uart, noise_until_s + 10 * LINE_RATE_S)
    after = [t for t in arrivals if t > noise_until_s]
    first_tick = math.ceil(noise_until_s / LINE_RATE_S - 1e-9) * LINE_RATE_S
    assert after[0] == pytest.approx(first_tick + FRAME_S, abs=2 * uart.byte_time_s)
    assert all(
        b - a == pytest.approx(LINE_RATE_S, abs=2 * uart.byte_time_s)
        for a, b in itertools.pairwise(after)
    )
    due = math.ceil(noise_until_s / LINE_RATE_S - 1e-9) - math.floor(at_s / LINE_RATE_S) - 1
    assert rc.frames_lost_to_noise == pytest.approx(due, abs=1)
    assert rc.frames_lost_to_noise <= count // 32 + 2  # what the oracle allows (fault_rules)


def test_injected_garbage_is_skipped_and_the_next_frame_survives() -> None:
    clock, uart, rc = running_transmitter()
    clock.advance(0.004)
    rc.inject_bytes(b"\x20\x20\x40\xff\x00garbage")
    clock.advance(2 * ibus.FRAME_PERIOD_S)
    parser = ibus.IbusParser()
    frames = parser.feed(uart.read_available())
    assert len(frames) == 3
    assert parser.stats.skipped_bytes >= 11
    assert uart.bytes_sent == 3 * 32 + 12
