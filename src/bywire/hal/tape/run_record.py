"""The run record: every input and output that crossed the controller's ports, as JSON lines.

What `bywire sim --record` writes and `bywire replay` reads. UTF-8, one JSON object per line,
gzip-compressed when the name ends in ``.gz``. Times are the controller's clock (virtual seconds);
floats are written as Python's shortest round-trip repr, so every value reads back bit-exact::

    line 1  {"format": "bywire-run-record", "version": 1, "scenario": "test-course",
             "start_s": 0.0, "end_s": 5.0, "pwm_period_s": {"steering": 0.02, ...},
             "sensors": ["wheel_speeds", ...], "config": "<robot TOML, as `config check`>",
             "authenticated": false}
    then    one event per line, in the order it happened: {"t": <s>, "kind": <kind>, ...}

    kind      fields                          meaning
    rc_bytes  hex, at (optional)              bytes one read of the RC UART returned, and when
                                              the newest of them arrived (the port's stamp)
    can_rx    frames: [[id, hex, stamp_s]]    frames one receive() of the CAN port returned
    sensor    name, read, value               the read-th read (from 0) of a sensor, when its
                                              value differs from the read before (null: none)
    refused   name ("can_tx"|"dac"), call     the call-th send or DAC write (from 0) failed
    stall     name ("dac"), call, s           the call-th DAC write hung s seconds in the driver
                                              (t: when it returned)
    link      name ("can"|"rc_uart"), down,   an input port's own state (`LinkState`), when a
              reopen_failures,                read of it differs from the read before (a run
              receive_failures                whose ports never fail has none)
    out       name, value                     an output: steering_pwm, hydrobrake_pwm (pulse s),
                                              gpio.<line> (level), dac.<channel> (I2C frame hex)
                                              when they change; can_tx.0x<id> (payload hex) for
                                              every frame the controller sends
"""

from __future__ import annotations

import contextlib
import gzip
import json
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from bywire.can_frame import CanFrame
from bywire.errors import ConfigError
from bywire.hal.ports import LinkState
from bywire.textfile import check_regular

FORMAT = "bywire-run-record"
VERSION = 1
SENSOR_NAMES = ("wheel_speeds", "hydrobrake_pressure_bar", "steering_encoder_norm", "estop_line")
"""The input ports noted as sensors (the E-stop's line as 1.0 high, 0.0 low)."""
LINK_NAMES = ("can", "rc_uart")

SensorValue = tuple[float, float] | float | None
OutputValue = float | bool | str
Event = dict[str, Any]


@dataclass(frozen=True, slots=True)
class RecordHeader:
    """The run as a whole: where it started and ended, the ports and the robot configuration."""

    scenario: str
    start_s: float
    end_s: float
    pwm_period_s: dict[str, float]
    sensors: tuple[str, ...]
    config_toml: str
    authenticated: bool = False
    """The controller verified SecOC-authenticated commands (with the key the configuration's
    `simulated_run_key` gives)."""

    def as_json(self) -> Event:
        return {
            "format": FORMAT,
            "version": VERSION,
            "scenario": self.scenario,
            "start_s": self.start_s,
            "end_s": self.end_s,
            "pwm_period_s": self.pwm_period_s,
            "sensors": list(self.sensors),
            "config": self.config_toml,
            "authenticated": self.authenticated,
        }

    @classmethod
    def from_json(cls, data: Event) -> RecordHeader:
        if not isinstance(data, dict) or data.get("format") != FORMAT:
            raise ValueError(f'not a {FORMAT} (first line has no "format": "{FORMAT}")')
        if data.get("version") != VERSION:
            raise ValueError(f"version {data.get('version')!r}, this bywire reads {VERSION}")
        periods = {str(name): float(value) for name, value in data["pwm_period_s"].items()}
        return cls(
            str(data["scenario"]),
            float(data["start_s"]),
            float(data["end_s"]),
            periods,
            tuple(str(name) for name in data["sensors"]),
            str(data["config"]),
            bool(data.get("authenticated", False)),
        )


@dataclass(frozen=True, slots=True)
class Output:
    """One output the controller wrote: at `time_s`, `name` took `value`."""

    time_s: float
    name: str
    value: OutputValue


@dataclass(slots=True)
class RecordedRun:
    """A record, split by kind: what replay feeds in, and the outputs it must reproduce."""

    header: RecordHeader
    rc_bytes: list[tuple[float, bytes, float | None]] = field(default_factory=list)
    """(read time, bytes, arrival stamp of the newest byte or None) of each RC UART read."""
    can_rx: list[tuple[float, list[CanFrame]]] = field(default_factory=list)
    sensor_reads: dict[str, list[tuple[int, SensorValue]]] = field(default_factory=dict)
    refusals: dict[str, set[int]] = field(default_factory=dict)
    stalls: dict[str, dict[int, float]] = field(default_factory=dict)
    """Per port, the calls that hung inside the driver and when each returned (clock time)."""
    links: dict[str, list[tuple[float, LinkState]]] = field(default_factory=dict)
    """Per input port ("can", "rc_uart"), each change of its `LinkState` and when it was read."""
    outputs: list[Output] = field(default_factory=list)

    def add(self, event: Event) -> None:
        """File one event; KeyError, TypeError or ValueError when it is malformed."""
        time_s, kind = float(event["t"]), event["kind"]
        if kind == "rc_bytes":
            at = event.get("at")
            arrived_at_s = None if at is None else float(at)
            self.rc_bytes.append((time_s, bytes.fromhex(event["hex"]), arrived_at_s))
        elif kind == "can_rx":
            frames = [CanFrame(int(i), bytes.fromhex(h), float(s)) for i, h, s in event["frames"]]
            self.can_rx.append((time_s, frames))
        elif kind == "sensor":
            reads = self.sensor_reads.setdefault(str(event["name"]), [])
            reads.append((int(event["read"]), _sensor_value(event["value"])))
        elif kind == "refused":
            self.refusals.setdefault(str(event["name"]), set()).add(int(event["call"]))
        elif kind == "stall":
            self.stalls.setdefault(str(event["name"]), {})[int(event["call"])] = time_s
        elif kind == "link":
            self.links.setdefault(_link_name(event["name"]), []).append((time_s, link_of(event)))
        elif kind == "out":
            self.outputs.append(Output(time_s, str(event["name"]), _output_value(event["value"])))
        else:
            raise ValueError(f"unknown event kind {kind!r}")


def link_event(name: str, link: LinkState) -> Event:
    """A link event's fields (without its time): what `Tape.add("link", ...)` takes."""
    return {
        "name": name,
        "down": link.down,
        "reopen_failures": link.reopen_failures,
        "receive_failures": link.receive_failures,
    }


def link_of(event: Event) -> LinkState:
    """The `LinkState` a link event holds; TypeError or ValueError when it is malformed."""
    down = event["down"]
    if not isinstance(down, bool):
        raise ValueError(f"link down {down!r}")
    return LinkState(down, int(event["reopen_failures"]), int(event["receive_failures"]))


def _link_name(name: object) -> str:
    if name not in LINK_NAMES:
        raise ValueError(f"link name {name!r} (one of {', '.join(LINK_NAMES)})")
    return str(name)


def _sensor_value(value: object) -> SensorValue:
    if value is None:
        return None
    if isinstance(value, list | tuple):
        left, right = value
        return (float(left), float(right))
    if isinstance(value, int | float) and not isinstance(value, bool):
        return float(value)
    raise ValueError(f"sensor value {value!r}")


def _output_value(value: object) -> OutputValue:
    if isinstance(value, bool | str):
        return value
    if isinstance(value, int | float):
        return float(value)
    raise ValueError(f"output value {value!r}")


def outputs_of(events: Iterable[Event]) -> list[Output]:
    """The outputs among events as a recorder produced them (the replay's side)."""
    return [Output(e["t"], e["name"], e["value"]) for e in events if e["kind"] == "out"]


# --- files ------------------------------------------------------------------------------------


def _open(path: Path, *, writing: bool) -> IO[str]:
    if path.suffix != ".gz":
        return path.open("w" if writing else "r", encoding="utf-8")
    if writing:
        return gzip.open(path, "wt", encoding="utf-8")
    return gzip.open(path, "rt", encoding="utf-8")


def write_record(path: Path, header: RecordHeader, events: Iterable[Event]) -> int:
    """Write a record; returns the number of events. ConfigError when the file cannot be
    written (a full disk: the file is cut back to its last whole line, which a reader takes)."""
    count = 0
    try:
        with _open(path, writing=True) as stream:
            stream.write(json.dumps(header.as_json()) + "\n")
            for event in events:
                stream.write(json.dumps(event, separators=(",", ":")) + "\n")
                count += 1
    except OSError as error:
        if path.suffix != ".gz":
            with contextlib.suppress(OSError):
                _cut_to_last_line(path)
        raise ConfigError(
            f"cannot write {path}: {error.strerror or error}: the record keeps the whole lines"
            " written before the failure"
        ) from None
    return count


def _cut_to_last_line(path: Path) -> None:
    with path.open("r+b") as file:
        data = file.read()
        file.truncate(data.rfind(b"\n") + 1)


def read_record(path: Path) -> RecordedRun:
    """Read a record; ConfigError naming the file and line for anything unreadable."""
    check_regular(path, "run record")  # /dev/zero or a FIFO would be read for ever
    try:
        with _open(path, writing=False) as stream:
            return _parse(path, enumerate(stream, start=1))
    except FileNotFoundError as error:
        raise ConfigError(f"{path}: no such run record") from error
    except (OSError, EOFError, UnicodeDecodeError) as error:
        reason = getattr(error, "strerror", None) or str(error)
        raise ConfigError(f"{path}: cannot read run record: {reason}") from error


def _parse(path: Path, lines: Iterator[tuple[int, str]]) -> RecordedRun:
    where, line = next(lines, (1, ""))
    try:
        run = RecordedRun(RecordHeader.from_json(json.loads(line or "null")))
        for number, text in lines:
            where = number
            if text.strip():
                run.add(json.loads(text))
    except (KeyError, TypeError, ValueError) as error:
        raise ConfigError(f"{path}: line {where}: not a valid run record: {error}") from error
    return run
