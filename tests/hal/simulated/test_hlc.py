"""Simulated higher-level computer: real commands at 50 Hz, each corruption caught, reports."""

from __future__ import annotations

import itertools
from dataclasses import replace

import pytest

from bywire.can_frame import CanFrame
from bywire.command_table import COMMANDS
from bywire.errors import FrameError
from bywire.hal.simulated.can_bus import SimCanBus
from bywire.hal.simulated.can_port import SimCanPort
from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.hlc import Corruption, SimHigherLevelComputer, out_of_range_payload
from bywire.model import (
    LIGHTS_OFF,
    ControlCommand,
    ControlMode,
    Gear,
    LightsCommand,
    ModeReport,
    MovementCommand,
    WheelSpeedReport,
)
from bywire.protocol import dbc


def hlc_on_bus() -> tuple[VirtualClock, SimCanBus, SimHigherLevelComputer, SimCanPort]:
    clock = VirtualClock()
    bus = SimCanBus(clock)
    hlc = SimHigherLevelComputer(clock, bus.attach("hlc"))
    controller = bus.attach("bywire", wake_on_receive=True)
    return clock, bus, hlc, controller


def decode_all(frames: list[CanFrame]) -> dict[int, list[object]]:
    """Decode every frame with the controller's own checks, counters tracked per id."""
    previous: dict[int, int | None] = dict.fromkeys(dbc.command_ids())
    decoded: dict[int, list[object]] = {frame_id: [] for frame_id in dbc.command_ids()}
    for frame in frames:
        command = dbc.decode_command(
            frame.arbitration_id, frame.data, previous[frame.arbitration_id]
        )
        previous[frame.arbitration_id] = command.counter
        decoded[frame.arbitration_id].append(command)
    return decoded


def test_three_commands_every_20_ms_with_consecutive_counters() -> None:
    clock, _, hlc, controller = hlc_on_bus()
    hlc.set_movement(0.25, 0.5, 0.0, Gear.FORWARD)
    hlc.set_lights(replace(LIGHTS_OFF, turn_left=True))
    hlc.set_control(remote_stop=False, re_enable=True)
    hlc.start()
    clock.advance(0.999)
    frames = controller.receive()
    decoded = decode_all(frames)  # raises CommandRejected on any bad frame or counter
    assert all(len(commands) == 50 for commands in decoded.values())
    movements = [
        command
        for command in decoded[dbc.frame_id(MovementCommand)]
        if isinstance(command, MovementCommand)
    ]
    assert [command.counter for command in movements] == [k % 16 for k in range(50)]
    assert movements[-1] == MovementCommand(0.25, 0.5, 0.0, Gear.FORWARD, 49 % 16)
    assert decoded[dbc.frame_id(LightsCommand)][0] == LightsCommand(True, False, False, False, 0)
    assert decoded[dbc.frame_id(ControlCommand)][0] == ControlCommand(False, True, 0)
    movement_times = [f.timestamp_s for f in frames if f.arbitration_id == 0x101]
    periods = [later - earlier for earlier, later in itertools.pairwise(movement_times)]
    assert periods == pytest.approx([0.02] * 49)
    assert hlc.frames_sent == 50 * len(COMMANDS)  # every row, every period


def test_silence_stops_the_commands_and_start_resumes_the_sequence() -> None:
    clock, _, hlc, controller = hlc_on_bus()
    hlc.start()
    clock.advance(0.09)
    assert len(controller.receive()) == 5 * len(COMMANDS)
    hlc.silence()
    assert not hlc.sending
    clock.advance(0.5)
    assert controller.receive() == []
    hlc.start()
    clock.advance(0.05)
    frames = controller.receive()
    assert len(frames) == 3 * len(COMMANDS)
    counters = [f.data[-2] & 0x0F for f in frames if f.arbitration_id == 0x101]
    assert counters == [5, 6, 7]


# LightsCommand and ControlCommand signals fill their bits: only movement can be out of range.
CORRUPTIONS = [
    (kind, message)
    for kind in Corruption
    for message in (MovementCommand, LightsCommand, ControlCommand)
    if kind is not Corruption.OUT_OF_RANGE or message is MovementCommand
]


@pytest.mark.parametrize(("kind", "message"), CORRUPTIONS)
def test_each_corruption_is_rejected_for_its_own_reason(
    kind: Corruption, message: type[MovementCommand | LightsCommand | ControlCommand]
) -> None:
    clock, _, hlc, controller = hlc_on_bus()
    hlc.start()
    clock.advance(0.03)  # two clean frames of each command
    hlc.corrupt_next(1, kind, message)
    clock.advance(0.02)
    frame_id = dbc.frame_id(message)
    frames = [f for f in controller.receive() if f.arbitration_id == frame_id]
    assert len(frames) == 3
    previous = dbc.decode_command(frame_id, frames[0].data, None).counter
    previous = dbc.decode_command(frame_id, frames[1].data, previous).counter
    with pytest.raises(dbc.CommandRejected) as rejected:
        dbc.decode_command(frame_id, frames[2].data, previous)
    assert rejected.value.reason is kind.value


@pytest.mark.parametrize("message", [LightsCommand, ControlCommand])
def test_out_of_range_is_refused_up_front_where_no_value_can_be(
    message: type[LightsCommand | ControlCommand],
) -> None:
    _, _, hlc, _ = hlc_on_bus()
    with pytest.raises(ValueError, match=message.__name__):
        hlc.corrupt_next(1, Corruption.OUT_OF_RANGE, message)


def test_a_corruption_damages_only_the_next_frames_of_its_message() -> None:
    clock, _, hlc, controller = hlc_on_bus()
    hlc.start()
    hlc.corrupt_next(2, Corruption.BAD_CRC)
    clock.advance(0.09)
    rejected_ids = []
    for frame in controller.receive():
        try:
            dbc.decode_command(frame.arbitration_id, frame.data, None)
        except dbc.CommandRejected as error:
            rejected_ids.append(error.frame_id)
    assert rejected_ids == [0x101, 0x101]


def test_out_of_range_payload_passes_the_crc_and_fails_the_range() -> None:
    command = MovementCommand(0.0, 0.0, 0.0, Gear.NEUTRAL, 3)
    payload = out_of_range_payload(command)
    assert payload[-1] == dbc.command_crc(0x101, payload)
    with pytest.raises(dbc.CommandRejected) as rejected:
        dbc.decode_command(0x101, payload, 2)
    assert rejected.value.reason is dbc.RejectReason.RANGE
    with pytest.raises(ValueError, match="LightsCommand"):
        out_of_range_payload(LightsCommand(False, False, False, False, 0))


def test_refused_frames_do_not_advance_the_counter() -> None:
    clock, bus, hlc, controller = hlc_on_bus()
    hlc.start()
    clock.advance(0.03)
    controller.receive()
    bus.unplug()
    clock.advance(0.1)
    assert hlc.send_refused > 0
    bus.plug()
    clock.advance(0.05)
    frames = controller.receive()
    counters = [f.data[-2] & 0x0F for f in frames if f.arbitration_id == 0x101]
    assert counters == [2, 3, 4]  # the frame queued before the cut, then fresh ones


def test_reports_are_decoded_and_stamped_and_other_frames_ignored() -> None:
    clock, _, hlc, controller = hlc_on_bus()
    assert hlc.latest(ModeReport) is None
    mode = ModeReport(Gear.FORWARD, ControlMode.CAN, False, False, True)
    for cycle in range(10):
        clock.advance(0.02 * cycle - clock.now())
        controller.send(CanFrame(*dbc.encode_report(mode)))
        controller.send(CanFrame(*dbc.encode_report(WheelSpeedReport(1.23, -0.5, True))))
        controller.send(CanFrame(0x333, b"\x00"))
    clock.advance(0.01)
    assert hlc.latest(ModeReport) == mode
    assert hlc.latest(WheelSpeedReport) == WheelSpeedReport(1.23, -0.5, True)
    arrivals = hlc.arrivals(ModeReport)
    assert len(arrivals) == 10
    assert [b - a for a, b in itertools.pairwise(arrivals)] == pytest.approx([0.02] * 9)
    assert hlc.latest_at(ModeReport) == arrivals[-1]
    assert hlc.report_errors == 0


def test_a_malformed_report_is_counted_not_raised() -> None:
    clock, _, hlc, controller = hlc_on_bus()
    controller.send(CanFrame(dbc.frame_id(ModeReport), b"\x00"))
    clock.advance(0.01)
    assert hlc.report_errors == 1
    assert hlc.latest(ModeReport) is None


@pytest.mark.parametrize(
    ("steering_norm", "throttle_norm"), [(1.5, 0.0), (0.0, -0.1), (float("nan"), 0.0)]
)
def test_set_movement_refuses_values_the_codec_cannot_send(
    steering_norm: float, throttle_norm: float
) -> None:
    _, _, hlc, _ = hlc_on_bus()
    with pytest.raises(FrameError):
        hlc.set_movement(steering_norm, throttle_norm, 0.0, Gear.FORWARD)
    assert hlc.current(MovementCommand).brake_norm == 1.0  # the previous set-points stay
