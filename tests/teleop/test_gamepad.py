"""Gamepad teleop: a recorded evdev stream (evemu format) through the pure mapping, in evdev's own
types; the dead man, the throttle lock, buttons on their press; a uinput pad where allowed."""

from __future__ import annotations

import asyncio
import os
from dataclasses import replace
from pathlib import Path

import can
import pytest
from textual.widgets import Static

evdev = pytest.importorskip("evdev", reason="evdev (the 'gamepad' extra) is Linux-only")
from evdev import AbsInfo, InputEvent, ecodes  # noqa: E402

from bywire.cli.teleop import GAMEPAD_HELP  # noqa: E402
from bywire.model import Gear, MovementCommand  # noqa: E402
from bywire.protocol import dbc  # noqa: E402
from bywire.teleop import gamepad  # noqa: E402
from bywire.teleop.gamepad import AxisRange, PadState, disconnected, step  # noqa: E402
from bywire.teleop.state import KEYS, TeleopState, advance  # noqa: E402
from tests.teleop import evemu  # noqa: E402

PERIOD_S = 0.02
RECORDING = evemu.DATA / "xbox360-drive.evemu"


def pad_of(axes: dict[int, AbsInfo]) -> PadState:
    """The pad as the shell builds it from the device's AbsInfo."""
    return PadState(
        ranges={code: AxisRange(info.min, info.max, info.flat) for code, info in axes.items()},
        values={code: info.value for code, info in axes.items()},
    )


def _time_s(event: InputEvent) -> float:
    return float(event.sec) + event.usec / 1e6


def drive_until(until_s: float) -> tuple[PadState, TeleopState]:
    """The recording played into the mapping one send period at a time, up to ``until_s``."""
    recording = evemu.read(RECORDING)
    pad, state = pad_of(recording.axes), TeleopState()
    pending = list(recording.events)
    now_s = 0.0
    while now_s < until_s - 1e-9:
        now_s = round(now_s + PERIOD_S, 6)
        due = [event for event in pending if _time_s(event) <= now_s]
        pending = pending[len(due) :]
        pad, state = step(pad, state, due, now_s)
        state = advance(state, now_s)
    return pad, state


def test_the_recording_is_read_into_evdevs_types() -> None:
    recording = evemu.read(RECORDING)
    assert recording.name == "Microsoft X-Box 360 pad"
    assert recording.axes[ecodes.ABS_X] == AbsInfo(0, -32768, 32767, 16, 128, 0)
    assert all(isinstance(event, InputEvent) for event in recording.events)
    assert evdev.categorize(recording.events[0]).event.code == ecodes.ABS_RZ


def test_without_the_dead_man_a_pulled_trigger_sends_full_brake() -> None:
    _, state = drive_until(0.2)
    assert (state.throttle_norm, state.brake_norm, state.steering_norm) == (0.0, 1.0, 0.0)


def test_a_gear_button_acts_on_its_press() -> None:
    assert drive_until(0.28)[1].gear is Gear.NEUTRAL
    assert drive_until(0.32)[1].gear is Gear.FORWARD
    assert drive_until(0.42)[1].gear is Gear.FORWARD  # the release changes nothing


def test_catching_the_dead_man_with_the_trigger_pulled_keeps_the_throttle_at_zero() -> None:
    pad, state = drive_until(0.6)
    assert pad.dead_man
    assert pad.throttle_locked
    assert (state.throttle_norm, state.brake_norm) == (0.0, 0.0)
    pad, state = drive_until(0.8)  # the trigger went back to rest
    assert not pad.throttle_locked


def test_held_the_sticks_and_triggers_drive() -> None:
    _, state = drive_until(0.92)
    assert state.throttle_norm == pytest.approx(128 / 255, abs=1e-4)
    assert state.brake_norm == 0.0
    assert state.steering_norm == pytest.approx((16384.5 - 128) / (32767.5 - 128), abs=1e-4)


def test_a_held_trigger_is_not_decayed_like_a_key() -> None:
    """Nothing changes on the pad from 0.9 s to 1.0 s, longer than the keyboard's hold time."""
    _, state = drive_until(0.98)
    assert state.throttle_norm == pytest.approx(128 / 255, abs=1e-4)


def test_the_stick_inside_its_flat_zone_steers_straight() -> None:
    assert drive_until(1.1)[1].steering_norm == 0.0


def test_a_d_pad_direction_toggles_its_light_once_per_press() -> None:
    assert not drive_until(1.18)[1].turn_left
    assert drive_until(1.22)[1].turn_left
    assert drive_until(1.3)[1].turn_left  # the hat's return to 0 is no second press


def test_full_lock_and_full_brake_reach_the_ends() -> None:
    _, state = drive_until(1.34)
    assert (state.steering_norm, state.brake_norm, state.throttle_norm) == (-1.0, 1.0, 0.5020)


def test_releasing_the_dead_man_gives_throttle_zero_full_brake_straight_steering() -> None:
    pad, state = drive_until(1.52)
    assert not pad.dead_man
    assert (state.throttle_norm, state.brake_norm, state.steering_norm) == (0.0, 1.0, 0.0)


def test_remote_stop_toggles_on_presses_and_ignores_auto_repeat() -> None:
    assert drive_until(1.72)[1].remote_stop
    assert not drive_until(1.92)[1].remote_stop  # pressed again; its repeat (value 2) ignored


def test_start_sends_the_re_enable_pulse() -> None:
    assert not drive_until(1.98)[1].re_enable
    assert drive_until(2.02)[1].re_enable


def test_lost_events_release_the_dead_man() -> None:
    _, held = drive_until(0.92)
    pad, _ = drive_until(0.92)
    dropped = InputEvent(1, 0, ecodes.EV_SYN, ecodes.SYN_DROPPED, 0)
    pad, state = step(pad, held, [dropped], 1.0)
    assert not pad.dead_man
    assert (state.throttle_norm, state.brake_norm) == (0.0, 1.0)


def test_a_lost_pad_brakes_even_with_the_dead_man_remembered_as_held() -> None:
    pad, state = drive_until(0.92)
    pad, state = step(disconnected(pad), state, [], 1.0)
    assert (state.throttle_norm, state.brake_norm) == (0.0, 1.0)
    press = InputEvent(1, 0, ecodes.EV_KEY, ecodes.BTN_TL, 1)  # stale events cannot re-arm it
    pad, state = step(pad, state, [press], 1.02)
    assert (state.throttle_norm, state.brake_norm) == (0.0, 1.0)


def test_an_axis_the_device_does_not_report_reads_zero() -> None:
    pad = replace(PadState(), dead_man=True)
    _, state = step(pad, TeleopState(), [InputEvent(0, 0, ecodes.EV_ABS, ecodes.ABS_RZ, 99)], 0.0)
    assert (state.throttle_norm, state.brake_norm, state.steering_norm) == (0.0, 0.0, 0.0)


def test_the_help_table_is_the_mapping_and_names_keyboard_actions() -> None:
    assert gamepad.help_lines() == GAMEPAD_HELP.splitlines()
    keys = {binding.key for binding in KEYS}
    assert {button.action for button in gamepad.BUTTONS} <= keys


# --- the device shell ----------------------------------------------------------------------


def test_a_gamepad_is_told_from_a_keyboard_by_its_capabilities() -> None:
    from bywire.teleop.gamepad_device import is_gamepad  # noqa: PLC0415

    pad = {ecodes.EV_KEY: [ecodes.BTN_SOUTH, ecodes.BTN_TL], ecodes.EV_ABS: [ecodes.ABS_X]}
    keyboard = {ecodes.EV_KEY: [ecodes.KEY_A, ecodes.KEY_SPACE]}
    assert is_gamepad(pad)
    assert not is_gamepad(keyboard)


UINPUT = Path("/dev/uinput")


@pytest.mark.skipif(
    not os.access(UINPUT, os.W_OK),
    reason=f"{UINPUT} is missing or not writable here: no virtual gamepad can be made",
)
def test_a_uinput_gamepad_is_opened_read_and_driven_like_the_recording() -> None:
    from bywire.teleop.gamepad_device import open_driver  # noqa: PLC0415

    recording = evemu.read(RECORDING)
    keys = sorted({event.code for event in recording.events if event.type == ecodes.EV_KEY})
    capabilities = {
        ecodes.EV_KEY: [*keys, ecodes.BTN_WEST, ecodes.BTN_SOUTH],
        ecodes.EV_ABS: list(recording.axes.items()),
    }
    with evdev.UInput(capabilities, name="bywire test pad") as virtual:
        driver = open_driver(Path(virtual.device.path))
        try:
            state = TeleopState()
            for event in [e for e in recording.events if _time_s(e) <= 0.92]:
                virtual.write(event.type, event.code, event.value)
            virtual.syn()
            state = driver.step(state, 1.0)
            assert driver.pad.dead_man
            assert state.gear is Gear.FORWARD
            assert state.throttle_norm == pytest.approx(128 / 255, abs=1e-4)
            assert "dead man held" in driver.status()
        finally:
            driver.close()


# --- the teleop program with a pad: what goes out on the bus --------------------------------


class RecordedReader:
    """The device end of ``GamepadDriver``, fed from the recording up to the program's clock."""

    lost: str | None = None
    name = "recorded pad (xbox360-drive.evemu)"

    def __init__(self, events: list[InputEvent], clock: list[float]) -> None:
        self._pending = list(events)
        self._clock = clock

    def poll(self) -> list[InputEvent]:
        due = [event for event in self._pending if _time_s(event) <= self._clock[0]]
        self._pending = self._pending[len(due) :]
        return due

    def close(self) -> None:
        self._pending = []


def _movements(robot: can.BusABC) -> list[MovementCommand]:
    frame = dbc.frame_id(MovementCommand)
    commands = []
    while (message := robot.recv(timeout=0.0)) is not None:
        if message.arbitration_id == frame:
            command = dbc.decode_command(frame, message.data, None)
            assert isinstance(command, MovementCommand)
            commands.append(command)
    return commands


async def _drive(teleop: can.BusABC, robot: can.BusABC) -> tuple[dict[float, MovementCommand], str]:
    """Tick the program on a simulated clock; what the robot received after each period."""
    from bywire.teleop.app import TeleopApp  # noqa: PLC0415
    from bywire.teleop.gamepad_device import GamepadDriver  # noqa: PLC0415

    recording = evemu.read(RECORDING)
    clock = [0.0]
    reader = RecordedReader(recording.events, clock)
    # GamepadDriver's reader is typed as the evdev-backed GamepadReader; this one plays a recording
    driver = GamepadDriver(reader, pad_of(recording.axes))  # type: ignore[arg-type]
    app = TeleopApp(teleop, now=lambda: clock[0], auto_tick=False, notifier=False, gamepad=driver)
    received: dict[float, MovementCommand] = {}
    status = ""
    async with app.run_test():
        for period in range(1, 80):
            clock[0] = round(period * PERIOD_S, 6)
            app.tick()
            [received[clock[0]]] = _movements(robot)
            if clock[0] == 0.92:
                status = str(app.query_one("#commands", Static).content)
    return received, status


def test_the_pad_drives_the_movement_commands_on_the_bus() -> None:
    channel = "gamepad-app-test"
    with (
        can.Bus(interface="virtual", channel=channel) as teleop,
        can.Bus(interface="virtual", channel=channel) as robot,
    ):
        received, status = asyncio.run(_drive(teleop, robot))
    assert (received[0.2].throttle_norm, received[0.2].brake_norm) == (0.0, 1.0)
    assert received[0.92].gear is Gear.FORWARD
    assert received[0.92].throttle_norm == pytest.approx(0.502, abs=1e-4)
    assert (received[1.52].throttle_norm, received[1.52].brake_norm) == (0.0, 1.0)
    assert "gamepad recorded pad (xbox360-drive.evemu)  dead man held: driving" in status
