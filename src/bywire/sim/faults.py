"""Every fault a scenario can inject, in one table: its name, what it does in words, what it
does to the simulated robot, and what the hazard oracle must expect of the outputs when it is
injected (its rule, `fault_rules.py`).

The scenario loader checks a fault's name against this table and `bywire sim --list` and the
README describe it from here; a run applies it through the same row, and `bywire verify`'s
witness tells the oracle through it. A new fault is a row here (and, if the world cannot yet do
it, a method on the simulated device; if the oracle must know of it, a rule).

A row's `apply` gets the run and the event's values: `count` (frames, bytes), `load` (a share of
the bus), `stall_s` (seconds), `line` (an output's name) and `keyed` (a second sender that has
the key), each defaulted by the loader.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from bywire.hal.sim.hlc import Corruption
from bywire.model import Command, ControlCommand, LightsCommand, MovementCommand
from bywire.sim.verify.fault_rules import (
    Expect,
    FaultValues,
    begins,
    can_back,
    can_fault,
    can_frames_lost,
    dac_fails,
    dac_restored,
    dac_slow,
    dac_stall,
    ebrake_fails,
    ends,
    hydrobrake,
    line_dead,
    nothing,
    rc_frames_lost,
    rc_implausible,
    second_sender,
    servo,
    switch_chatter,
    wheel_sensor,
)
from bywire.sim.verify.oracle.causes import Cause

if TYPE_CHECKING:
    from bywire.sim.runner import SimRun

Apply = Callable[["SimRun", FaultValues], None]


@dataclass(frozen=True, slots=True)
class Fault:
    """One fault: its name in a scenario, its description, how the run applies it, and what
    the oracle must expect then."""

    name: str
    description: str
    apply: Apply
    expect: Expect


def _count(values: FaultValues) -> int:
    return int(values["count"])


def _corrupt(how: Corruption) -> Apply:
    def apply(run: SimRun, values: FaultValues) -> None:
        run.world.hlc.corrupt_next(_count(values), how)

    return apply


def _hydrobrake(failed: bool) -> Apply:
    def apply(run: SimRun, _values: FaultValues) -> None:
        run.world.vehicle.faults.hydrobrake_failed = failed

    return apply


def _servo(stuck: bool) -> Apply:
    def apply(run: SimRun, _values: FaultValues) -> None:
        run.world.vehicle.faults.servo_stuck = stuck

    return apply


def _ebrake_fail(run: SimRun, _values: FaultValues) -> None:
    run.world.vehicle.faults.ebrake_failed = True


def _encoder_fail(run: SimRun, _values: FaultValues) -> None:
    run.world.steering_encoder.failed = True


def _impostor(kind: type[Command], *, forge: bool = False, skip: bool = False) -> Apply:
    def apply(run: SimRun, values: FaultValues) -> None:
        keyed = bool(values.get("keyed"))
        impostor = run.world.impostors[kind]
        impostor.start(_count(values), kind=kind, keyed=keyed, forge=forge, skip=skip)

    return apply


def _doubles(run: SimRun, values: FaultValues) -> None:
    run.world.hlc.doubles_pending = _count(values)


def _line_dead(run: SimRun, values: FaultValues) -> None:
    run.world.output(str(values["line"])).fail()


def _ibus_garbage(run: SimRun, values: FaultValues) -> None:
    run.world.rc.inject_bytes(run.random.randbytes(_count(values)))


# fmt: off
FAULTS: tuple[Fault, ...] = (
    Fault("rc_link_lost", "the RC receiver stops sending (unplugged, or the UART dies)",
          lambda run, _v: run.world.rc.link_lost(),
          expect=begins(Cause.RC_LINK_LOST)),
    Fault("rc_link_restored", "the RC receiver sends again",
          lambda run, _v: run.world.rc.link_restored(),
          expect=ends(Cause.RC_LINK_LOST)),
    Fault("rc_failsafe", "the receiver sends its failsafe values (transmitter out of range)",
          lambda run, _v: run.world.rc.failsafe(run.failsafe_values()),
          expect=begins(Cause.RC_FAILSAFE)),
    Fault("rc_failsafe_off", "the transmitter is back in range",
          lambda run, _v: run.world.rc.failsafe_off(),
          expect=ends(Cause.RC_FAILSAFE)),
    Fault("ibus_garbage", "`count` random bytes on the RC line", _ibus_garbage,
          expect=rc_frames_lost(lambda n: n // 32 + 2)),
    Fault("ibus_corrupt", "the next `count` IBUS frames have a corrupted byte",
          lambda run, v: run.world.rc.corrupt_next_frames(_count(v)),
          expect=rc_frames_lost(lambda n: n + 1)),
    Fault("can_silence", "the higher-level computer (or the bridge) stops sending commands",
          lambda run, _v: run.computer.silence(),
          expect=can_fault(Cause.CAN_LOST)),
    Fault("can_resume", "the higher-level computer (or the bridge) sends again",
          lambda run, _v: run.computer.start(),
          expect=can_back(Cause.CAN_LOST)),
    Fault("can_corrupt_crc", "the next `count` command frames carry a bad CRC",
          _corrupt(Corruption.BAD_CRC),
          expect=can_frames_lost),
    Fault("can_corrupt_length", "the next `count` command frames have the wrong length",
          _corrupt(Corruption.WRONG_LENGTH),
          expect=can_frames_lost),
    Fault("can_corrupt_counter", "the next `count` command frames repeat their counter",
          _corrupt(Corruption.REPEATED_COUNTER),
          expect=can_frames_lost),
    Fault("can_corrupt_range", "the next `count` command frames carry an out-of-range value",
          _corrupt(Corruption.OUT_OF_RANGE),
          expect=can_frames_lost),
    Fault("dac_fail", "every DAC write is NAKed from now on",
          lambda run, _v: run.world.dac.fail_writes(),
          expect=dac_fails(every_other=False)),
    Fault("dac_restore", "DAC writes succeed again",
          lambda run, _v: run.world.dac.stop_failing(),
          expect=dac_restored),
    Fault("can_unplug", "the CAN cable is pulled: nothing is delivered, transmit queues fill",
          lambda run, _v: run.world.bus.unplug(),
          expect=can_fault(Cause.CAN_UNPLUGGED)),
    Fault("can_plug", "the CAN cable is back",
          lambda run, _v: run.world.bus.plug(),
          expect=can_back(Cause.CAN_UNPLUGGED)),
    Fault("can_flood", "other nodes fill `load` (0…1) of the bus with lower-priority frames",
          lambda run, v: run.world.bus.flood(float(v["load"])),
          expect=nothing),
    Fault("can_flood_off", "the other nodes stop",
          lambda run, _v: run.world.bus.stop_flood(),
          expect=nothing),
    Fault("hydrobrake_fail", "the hydraulic brake builds no pressure and does not brake",
          _hydrobrake(True),
          expect=hydrobrake(failed=True)),
    Fault("hydrobrake_restore", "the hydraulic brake works again", _hydrobrake(False),
          expect=hydrobrake(failed=False)),
    Fault("ebrake_fail", "the spring-applied emergency brake does not engage", _ebrake_fail,
          expect=ebrake_fails),
    Fault("servo_stuck", "the steering servo stays where it is", _servo(True),
          expect=servo(stuck=True)),
    Fault("servo_free", "the steering servo moves again", _servo(False),
          expect=servo(stuck=False)),
    Fault("encoder_fail", "the steering encoder gives no reading", _encoder_fail,
          expect=nothing),
    Fault("loop_stall", "the control loop hangs for `stall_s` (needs realtime = true: the "
          "watchdog's limit is wall-clock time)",
          lambda run, v: run.stall_loop(float(v["stall_s"])),
          expect=nothing),
    Fault("dac_stall", "the next DAC write hangs inside the I2C driver for `stall_s` (virtual "
          "time too)",
          lambda run, v: run.world.dac.stall_next_write(float(v["stall_s"])),
          expect=dac_stall),
    Fault("dac_nak_alternate", "every other DAC write is NAKed from now on (dac_restore ends it)",
          lambda run, _v: run.world.dac.fail_pattern((True, False)),
          expect=dac_fails(every_other=True)),
    Fault("switch_chatter", "the mode switch bounces: of the next `count` IBUS frames every "
          "other one reads STOP",
          lambda run, v: run.world.rc.chatter_next_frames(_count(v)),
          expect=switch_chatter),
    Fault("switch_dither", "the mode switch's pulse dithers ±4 µs for the next `count` IBUS "
          "frames (a knob left between two positions)",
          lambda run, v: run.world.rc.dither_next_frames(_count(v)),
          expect=nothing),
    Fault("rc_implausible", "the next `count` IBUS frames are intact but carry a pulse no stick "
          "gives",
          lambda run, v: run.world.rc.implausible_next_frames(_count(v)),
          expect=rc_implausible),
    Fault("can_impostor", "a second node sends `count` movement commands on the computer's id, "
          "each with the counter the computer will use next, asking for throttle 0.8 (with "
          "authentication: without the key, unless `keyed`)",
          _impostor(MovementCommand),
          expect=second_sender),
    Fault("can_impostor_control", "a second node (an idle teleop) sends `count` control "
          "commands, neither stop nor re-enable, on the computer's id with its next counter",
          _impostor(ControlCommand),
          expect=nothing),
    Fault("can_forgery", "a second node answers each of `count` movement frames with a bad-CRC "
          "frame and a forgery carrying the counter just used (full right lock, throttle 0.8)",
          _impostor(MovementCommand, forge=True),
          expect=second_sender),
    Fault("can_skip_forgery", "a second node answers each of `count` movement frames with a "
          "bad-CRC frame and a forgery carrying the counter after the computer's next, skipping "
          "it (full right lock, throttle 0.8)",
          _impostor(MovementCommand, forge=True, skip=True),
          expect=second_sender),
    Fault("can_doubles", "the computer sends each of its next `count` movement frames twice, same "
          "counter and payload (a driver's bug, or a redundant scheme): harmless",
          _doubles,
          expect=nothing),
    Fault("can_impostor_lights", "a second node sends `count` lights commands (hazard on) on "
          "the computer's id with its next counter",
          _impostor(LightsCommand),
          expect=nothing),
    Fault("dac_slow", "every DAC transfer takes `stall_s` and succeeds (dac_restore ends it)",
          lambda run, v: run.world.dac.slow_writes(float(v["stall_s"])),
          expect=dac_slow),
    Fault("line_dead", "the output `line` (a GPIO line, or the steering or hydrobrake PWM) "
          "dies: every write to it fails",
          _line_dead,
          expect=line_dead),
    Fault("wheel_sensor_dead", "the wheel-speed sensor reads 0 m/s from now on, whatever the "
          "wheels do",
          lambda run, _v: run.world.wheel_sensor.die(),
          expect=wheel_sensor(dead=True)),
    Fault("wheel_sensor_restore", "the wheel-speed sensor tells the truth again",
          lambda run, _v: run.world.wheel_sensor.restore(),
          expect=wheel_sensor(dead=False)),
)
# fmt: on
BY_NAME: dict[str, Fault] = {fault.name: fault for fault in FAULTS}
