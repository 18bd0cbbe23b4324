"""The robot's transmitter and higher-level computer, in a process of their own at a real-time
priority above bywire's.

On the robot they are other machines: nothing the robot's computer does delays them. In the
guest they share its one CPU with bywire, which runs at SCHED_FIFO as on the robot. The guest is
about 80 % busy in the course on a quiet host (bywire 60 %, the rig's process 20 %); on a host
1.3 times slower (CI, 2026-12-07) it was saturated, bywire's real-time priority took the CPU,
and the senders, in the test's own process at normal priority, went silent for up to 1.9 s:
bywire rightly stopped, and the course failed. So the senders run here, at `priority` (above
bywire's), and cost the guest a few per cent; only the test's readings, an observer, wait for
a turn on a saturated guest.

Usage: python -m tests.kernel.senders ROBOT_FILE CAN_CHANNEL RC_TTY PRIORITY LOG

It says `ready` on stdout once both are running, then reads one JSON object per line on stdin
and answers `ok` on stdout once it is applied:
  {"kind": KIND, "values": {...}}  a scenario's `rc` action (the transmitter sends at once), or
                                   its `hlc`, `hlc_lights` or `hlc_control` action (the computer
                                   starts sending at its first)
  {"play": START_S, "events": [{"at_s": S, "kind": KIND, "values": {...}}, ...]}
                                   such actions, each at monotonic START_S + S (`Schedule`)
  {"transmitter": false}           the transmitter falls silent (true: it sends again)
End of file on stdin ends it. LOG gets, one per line, `priority fifo N` (or `priority normal:
REASON`), `stall transmitter|computer MONOTONIC_S GAP_S` for every gap over STALL_S between two
sends, `applied INDEX MONOTONIC_S` for each scheduled action, and `error TEXT` for every command
the computer could not send.
"""

from __future__ import annotations

import dataclasses
import json
import os
import sys
import threading
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any, TextIO

import can

from bywire.config import RobotConfig, parse_config
from bywire.hal.simulated.rc_transmitter import idle_channels, raw_for_axis, raw_for_switch
from bywire.model import ControlCommand, ControlMode, Gear, LightsCommand, MovementCommand
from bywire.protocol import dbc, ibus
from tests.kernel import guest

COMMAND_PERIOD_S = 0.02
STALL_S = 0.1  # a gap this long between two sends of the transmitter or computer is recorded
FRAMES_PER_WRITE = 3  # frames handed to the host at once: a third of the guest's work for it


class Log:
    """LOG's lines, from any of the senders' threads."""

    def __init__(self, out: TextIO) -> None:
        self._out = out
        self._lock = threading.Lock()

    def line(self, text: str) -> None:
        with self._lock:
            self._out.write(text + "\n")
            self._out.flush()

    def stall(self, who: str, last_s: float) -> float:
        """Now, after logging a gap since `last_s` longer than STALL_S: the guest did not run
        this sender (the robot's input stopped for that long, as bywire saw it)."""
        now_s = time.monotonic()
        if now_s - last_s > STALL_S:
            self.line(f"stall {who} {now_s:.6f} {now_s - last_s:.6f}")
        return now_s


class Transmitter:
    """The operator's sticks and switches, as IBUS frames on the RC tty every 7.7 ms (handed to
    the host `FRAMES_PER_WRITE` at a time: the receiver's bytes arrive in bursts of 23 ms)."""

    def __init__(self, host: guest.HostLine, config: RobotConfig, log: Log) -> None:
        self.mapping = config.rc.mapping
        self._host = host
        self._log = log
        self._channels = list(idle_channels(self.mapping))
        self._lock = threading.Lock()
        self.sending = True
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="transmitter")

    def start(self) -> None:
        self._thread.start()

    def apply(self, values: Mapping[str, Any]) -> None:
        """A scenario's `rc = {…}` action."""
        mapping = self.mapping
        with self._lock:
            if "mode" in values:
                position = mapping.mode_positions.index(ControlMode[str(values["mode"]).upper()])
                self._set(
                    mapping.mode_switch.channel, raw_for_switch(position, mapping.mode_switch)
                )
            if "gear" in values:
                position = mapping.gear_positions.index(Gear[str(values["gear"]).upper()])
                self._set(
                    mapping.gear_switch.channel, raw_for_switch(position, mapping.gear_switch)
                )
            if "steering" in values:
                axis = mapping.steering
                self._set(axis.channel, raw_for_axis(float(values["steering"]), axis))
            if "throttle" in values:
                axis = mapping.throttle_brake
                self._set(axis.channel, raw_for_axis(float(values["throttle"]), axis))

    def _set(self, channel: int, raw: int) -> None:
        self._channels[channel] = raw

    def _run(self) -> None:
        next_s = sent_s = time.monotonic()
        while not self._stop.wait(max(0.0, next_s - time.monotonic())):
            next_s += ibus.FRAME_PERIOD_S * FRAMES_PER_WRITE
            if self.sending:
                with self._lock:
                    frame = ibus.encode_frame(self._channels)
                self._host.send_rc(frame * FRAMES_PER_WRITE)
                sent_s = self._log.stall("transmitter", sent_s)
            else:
                sent_s = time.monotonic()  # silent on purpose: no stall

    def close(self) -> None:
        self._stop.set()
        self._thread.join()


class Computer:
    """The higher-level computer's commands on the CAN interface at 50 Hz, with counters and
    CRC (its reports are read by the test's own process: `robot.Computer`)."""

    def __init__(self, channel: str, log: Log) -> None:
        # receives nothing: an id no frame of the robot's carries, matched exactly
        quiet = [{"can_id": 0x7FF, "can_mask": 0x7FF, "extended": False}]
        self.bus = can.Bus(interface="socketcan", channel=channel, can_filters=quiet)
        self._log = log
        self.movement = MovementCommand(0.0, 0.0, 1.0, Gear.NEUTRAL, 0)
        self.lights = LightsCommand(False, False, False, False, 0)
        self.control = ControlCommand(False, False, 0)
        self.sending = False
        self._movement: dict[str, Any] = {"steering": 0.0, "throttle": 0.0, "brake": 1.0}
        self._movement["gear"] = "neutral"
        self._counters: dict[type, int] = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._send_loop, name="hlc-tx")

    def start(self) -> None:
        self._thread.start()

    def apply(self, kind: str, values: Mapping[str, Any]) -> None:
        """A scenario's `hlc`, `hlc_lights` or `hlc_control` action (sending starts at the
        first)."""
        if kind == "hlc":
            self._movement.update(values)
            moving = self._movement
            self.movement = MovementCommand(
                float(moving["steering"]), float(moving["throttle"]), float(moving["brake"]),
                Gear[str(moving["gear"]).upper()], 0,
            )  # fmt: skip
        elif kind == "hlc_lights":
            off = {"turn_left": False, "turn_right": False, "hazard": False, "low_beam": False}
            self.lights = LightsCommand(**{**off, **values}, counter=0)
        else:
            self.control = ControlCommand(
                bool(values.get("remote_stop", False)), bool(values.get("re_enable", False)), 0
            )
        self.sending = True

    def _send_loop(self) -> None:
        next_s = sent_s = time.monotonic()
        while not self._stop.wait(max(0.0, next_s - time.monotonic())):
            next_s += COMMAND_PERIOD_S
            if self.sending:
                for command in (self.control, self.movement, self.lights):
                    self._send(command)
                sent_s = self._log.stall("computer", sent_s)
            else:
                sent_s = time.monotonic()  # not started yet: no stall

    def _send(self, command: MovementCommand | LightsCommand | ControlCommand) -> None:
        counter = self._counters.get(type(command), 0)
        frame_id, payload = dbc.encode_command(dataclasses.replace(command, counter=counter))
        try:
            self.bus.send(can.Message(arbitration_id=frame_id, data=payload, is_extended_id=False))
        except can.CanError as error:
            self._log.line(f"error {error}")
            return
        self._counters[type(command)] = (counter + 1) % dbc.COUNTER_MODULUS

    def close(self) -> None:
        self._stop.set()
        self._thread.join()
        self.bus.shutdown()


class Schedule:
    """A scenario's actions, each applied at its time by `apply(kind, values)` from a thread of
    this process: the operator and the computer act on time however busy the guest is (when
    the test's own process played them, a 1.6 s wait for a turn put the switch to RC and the
    stick forward in one instant, and bywire rightly refused to arm). LOG gets `applied INDEX
    MONOTONIC_S` for each."""

    def __init__(self, apply: Any, log: Log) -> None:
        self._apply = apply
        self._log = log
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def play(self, start_s: float, events: list[dict[str, Any]]) -> None:
        """`events` ({"at_s", "kind", "values"}, in time order) from monotonic `start_s`."""
        self.close()
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, args=(start_s, events), name="events")
        self._thread.start()

    def _run(self, start_s: float, events: list[dict[str, Any]]) -> None:
        for index, event in enumerate(events):
            if self._stop.wait(max(0.0, start_s + float(event["at_s"]) - time.monotonic())):
                return
            self._apply(str(event["kind"]), event["values"])
            self._log.line(f"applied {index} {time.monotonic():.6f}")

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join()


def _raise_priority(priority: int, log: Log) -> None:
    """SCHED_FIFO at `priority` for this process's threads (those started after this)."""
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except OSError as error:
        log.line(f"priority normal: {error}")
    else:
        log.line(f"priority fifo {priority}")


def main(args: list[str]) -> int:
    config_path, channel, rc_tty, priority, log_path = args
    config = parse_config(Path(config_path).read_text())
    with open(log_path, "w", encoding="utf-8") as out:
        log = Log(out)
        _raise_priority(int(priority), log)
        host = guest.HostLine(rc_tty)
        transmitter = Transmitter(host, config, log)
        computer = Computer(channel, log)
        transmitter.start()
        computer.start()

        def apply(kind: str, values: Mapping[str, Any]) -> None:
            if kind == "rc":
                transmitter.apply(values)
            else:
                computer.apply(kind, values)

        schedule = Schedule(apply, log)
        sys.stdout.write("ready\n")
        sys.stdout.flush()
        try:
            for line in sys.stdin:
                request = json.loads(line)
                if "play" in request:
                    schedule.play(float(request["play"]), request["events"])
                elif "kind" in request:
                    apply(request["kind"], request["values"])
                else:
                    transmitter.sending = bool(request["transmitter"])
                sys.stdout.write("ok\n")
                sys.stdout.flush()
        finally:
            schedule.close()
            transmitter.close()
            computer.close()
            host.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
