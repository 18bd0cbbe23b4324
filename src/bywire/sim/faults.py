"""Every fault a scenario can inject, in one table: its name, what it does in words, and what
it does to the simulated robot.

The scenario loader checks a fault's name against this table and `bywire sim --list` and the
README describe it from here; a run applies it through the same row. The scenario language
stands alone: what the hazard oracle must expect of the outputs when a fault is injected is
`bywire verify`'s business, one rule per row name in `sim/verify/fault_rules.py` (a test keeps
the two tables in step). A new fault is a row here (and, if the world cannot yet do it, a method
on the simulated device), and a rule there.

A row's `apply` gets the run and the event's values: `count` (frames, bytes), `load` (a share of
the bus), `stall_s` (seconds), `line` (an output's name) and `keyed` (a second sender that has
the key), each defaulted by the loader.
"""

from __future__ import annotations

import random
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

from bywire.hal.simulated.hlc import Corruption
from bywire.hal.simulated.world import SimWorld
from bywire.model import Command, ControlCommand, LightsCommand, MovementCommand

FaultValues = Mapping[str, Any]
"""A fault event's values, defaulted by the loader."""


class SilencedComputer(Protocol):
    """The simulated higher-level computer (or the bridge) that a CAN fault silences."""

    def start(self) -> None: ...
    def silence(self) -> None: ...


class FaultTarget(Protocol):
    """What a fault acts on: a running simulated robot (`sim.runner.SimRun` is one)."""

    @property
    def world(self) -> SimWorld: ...
    @property
    def computer(self) -> SilencedComputer: ...
    @property
    def random(self) -> random.Random: ...
    def failsafe_values(self) -> dict[int, int]: ...
    def stall_loop(self, stall_s: float) -> None: ...


Apply = Callable[[FaultTarget, FaultValues], None]


@dataclass(frozen=True, slots=True)
class Fault:
    """One fault: its name in a scenario, its description, and how the run applies it."""

    name: str
    description: str
    apply: Apply


def _count(values: FaultValues) -> int:
    return int(values["count"])


def _corrupt(how: Corruption) -> Apply:
    def apply(run: FaultTarget, values: FaultValues) -> None:
        run.world.hlc.corrupt_next(_count(values), how)

    return apply


def _hydrobrake(failed: bool) -> Apply:
    def apply(run: FaultTarget, _values: FaultValues) -> None:
        run.world.vehicle.faults.hydrobrake_failed = failed

    return apply


def _servo(stuck: bool) -> Apply:
    def apply(run: FaultTarget, _values: FaultValues) -> None:
        run.world.vehicle.faults.servo_stuck = stuck

    return apply


def _ebrake_fail(run: FaultTarget, _values: FaultValues) -> None:
    run.world.vehicle.faults.ebrake_failed = True


def _encoder_fail(run: FaultTarget, _values: FaultValues) -> None:
    run.world.steering_encoder.failed = True


def _impostor(kind: type[Command], *, forge: bool = False, skip: bool = False) -> Apply:
    def apply(run: FaultTarget, values: FaultValues) -> None:
        keyed = bool(values.get("keyed"))
        impostor = run.world.impostors[kind]
        impostor.start(_count(values), kind=kind, keyed=keyed, forge=forge, skip=skip)

    return apply


def _doubles(run: FaultTarget, values: FaultValues) -> None:
    run.world.hlc.doubles_pending = _count(values)


def _line_dead(run: FaultTarget, values: FaultValues) -> None:
    run.world.output(str(values["line"])).fail()


def _ibus_garbage(run: FaultTarget, values: FaultValues) -> None:
    run.world.rc.inject_bytes(run.random.randbytes(_count(values)))


# fmt: off
FAULTS: tuple[Fault, ...] = (
    Fault("rc_link_lost", "the RC receiver stops sending (unplugged, or the UART dies)",
          lambda run, _v: run.world.rc.link_lost()),
    Fault("rc_link_restored", "the RC receiver sends again",
          lambda run, _v: run.world.rc.link_restored()),
    Fault("rc_failsafe", "the receiver sends its failsafe values (transmitter out of range)",
          lambda run, _v: run.world.rc.failsafe(run.failsafe_values())),
    Fault("rc_failsafe_off", "the transmitter is back in range",
          lambda run, _v: run.world.rc.failsafe_off()),
    Fault("ibus_garbage", "`count` random bytes on the RC line (noise: the frames it covers lost)",
          _ibus_garbage),
    Fault("ibus_corrupt", "the next `count` IBUS frames have a corrupted byte",
          lambda run, v: run.world.rc.corrupt_next_frames(_count(v))),
    Fault("can_silence", "the higher-level computer (or the bridge) stops sending commands",
          lambda run, _v: run.computer.silence()),
    Fault("can_resume", "the higher-level computer (or the bridge) sends again",
          lambda run, _v: run.computer.start()),
    Fault("can_corrupt_crc", "the next `count` command frames carry a bad CRC",
          _corrupt(Corruption.BAD_CRC)),
    Fault("can_corrupt_length", "the next `count` command frames have the wrong length",
          _corrupt(Corruption.WRONG_LENGTH)),
    Fault("can_corrupt_counter", "the next `count` command frames repeat their counter",
          _corrupt(Corruption.REPEATED_COUNTER)),
    Fault("can_corrupt_range", "the next `count` command frames carry an out-of-range value",
          _corrupt(Corruption.OUT_OF_RANGE)),
    Fault("dac_fail", "every DAC write is NAKed from now on",
          lambda run, _v: run.world.dac.fail_writes()),
    Fault("dac_restore", "DAC writes succeed again",
          lambda run, _v: run.world.dac.stop_failing()),
    Fault("can_unplug", "the CAN cable is pulled: nothing is delivered, transmit queues fill",
          lambda run, _v: run.world.bus.unplug()),
    Fault("can_plug", "the CAN cable is back",
          lambda run, _v: run.world.bus.plug()),
    Fault("can_flood", "other nodes fill `load` (0…1) of the bus with lower-priority frames",
          lambda run, v: run.world.bus.flood(float(v["load"]))),
    Fault("can_flood_off", "the other nodes stop",
          lambda run, _v: run.world.bus.stop_flood()),
    Fault("hydrobrake_fail", "the hydraulic brake builds no pressure and does not brake",
          _hydrobrake(True)),
    Fault("hydrobrake_restore", "the hydraulic brake works again", _hydrobrake(False)),
    Fault("ebrake_fail", "the spring-applied emergency brake does not engage", _ebrake_fail),
    Fault("servo_stuck", "the steering servo stays where it is", _servo(True)),
    Fault("servo_free", "the steering servo moves again", _servo(False)),
    Fault("encoder_fail", "the steering encoder gives no reading", _encoder_fail),
    Fault("loop_stall", "the control loop hangs for `stall_s` (needs realtime = true: the "
          "watchdog's limit is wall-clock time)",
          lambda run, v: run.stall_loop(float(v["stall_s"]))),
    Fault("dac_stall", "the next DAC write hangs inside the I2C driver for `stall_s` (virtual "
          "time too)",
          lambda run, v: run.world.dac.stall_next_write(float(v["stall_s"]))),
    Fault("dac_nak_alternate", "every other DAC write is NAKed from now on (dac_restore ends it)",
          lambda run, _v: run.world.dac.fail_pattern((True, False))),
    Fault("switch_chatter", "the mode switch bounces: of the next `count` IBUS frames every "
          "other one reads STOP",
          lambda run, v: run.world.rc.chatter_next_frames(_count(v))),
    Fault("switch_dither", "the mode switch's pulse dithers ±4 µs for the next `count` IBUS "
          "frames (a knob left between two positions)",
          lambda run, v: run.world.rc.dither_next_frames(_count(v))),
    Fault("rc_implausible", "the next `count` IBUS frames are intact but carry a pulse no stick "
          "gives",
          lambda run, v: run.world.rc.implausible_next_frames(_count(v))),
    Fault("can_impostor", "a second node sends `count` movement commands on the computer's id, "
          "each with the counter the computer will use next, asking for throttle 0.8 (with "
          "authentication: without the key, unless `keyed`)",
          _impostor(MovementCommand)),
    Fault("can_impostor_control", "a second node (an idle teleop) sends `count` control "
          "commands, neither stop nor re-enable, on the computer's id with its next counter",
          _impostor(ControlCommand)),
    Fault("can_forgery", "a second node answers each of `count` movement frames with a bad-CRC "
          "frame and a forgery carrying the counter just used (full right lock, throttle 0.8)",
          _impostor(MovementCommand, forge=True)),
    Fault("can_skip_forgery", "a second node answers each of `count` movement frames with a "
          "bad-CRC frame and a forgery carrying the counter after the computer's next, skipping "
          "it (full right lock, throttle 0.8)",
          _impostor(MovementCommand, forge=True, skip=True)),
    Fault("can_doubles", "the computer sends each of its next `count` movement frames twice, same "
          "counter and payload (a driver's bug, or a redundant scheme): harmless",
          _doubles),
    Fault("can_impostor_lights", "a second node sends `count` lights commands (hazard on) on "
          "the computer's id with its next counter",
          _impostor(LightsCommand)),
    Fault("dac_slow", "every DAC transfer takes `stall_s` and succeeds (dac_restore ends it)",
          lambda run, v: run.world.dac.slow_writes(float(v["stall_s"]))),
    Fault("line_dead", "the output `line` (a GPIO line, or the steering or hydrobrake PWM) "
          "dies: every write to it fails",
          _line_dead),
    Fault("wheel_sensor_dead", "the wheel-speed sensor reads 0 m/s from now on, whatever the "
          "wheels do",
          lambda run, _v: run.world.wheel_sensor.die()),
    Fault("wheel_sensor_restore", "the wheel-speed sensor tells the truth again",
          lambda run, _v: run.world.wheel_sensor.restore()),
    Fault("estop_press", "the safety operator presses the E-stop (its circuit opens)",
          lambda run, _v: run.world.estop.press()),
    Fault("estop_release", "the E-stop is released (its circuit closes)",
          lambda run, _v: run.world.estop.release()),
    Fault("estop_wire_break", "the E-stop's wire breaks (its circuit opens, as if pressed)",
          lambda run, _v: run.world.estop.break_wire()),
    Fault("estop_wire_mend", "the E-stop's wire is mended",
          lambda run, _v: run.world.estop.mend_wire()),
    Fault("estop_chatter", "the E-stop is pressed and its contact bounces: of the next `count` "
          "reads of its line every other one reads released, then it stays pressed",
          lambda run, v: run.world.estop.chatter(_count(v))),
)
# fmt: on
BY_NAME: dict[str, Fault] = {fault.name: fault for fault in FAULTS}
