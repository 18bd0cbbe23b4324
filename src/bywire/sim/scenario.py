"""Scenarios as data: timed events on the simulated robot and expectations to check (TOML).

A scenario file::

    name = "rc-link-lost"
    description = "RC receiver unplugged while driving by RC"
    duration_s = 6.0

    [[event]]                       # every event: at_s, optional label, one action
    at_s = 0.5
    rc = { mode = "stop" }          # RC sticks and switches (see ACTIONS)
    [[event]]
    at_s = 1.0
    rc = { mode = "rc", gear = "forward", throttle = 0.4 }
    [[event]]
    at_s = 4.0
    label = "unplugged"
    fault = "rc_link_lost"          # see FAULTS; some take `count` or `load`

    [[expect]]                      # within_s of a labelled event, throughout during_s after
                                    # it, or at a time (at_s)
    after = "unplugged"
    within_s = 0.110
    mode = "stop"
    throttle_volts_max = 0.0
    ebrake_engaged = true

Other actions: `hlc = { steering, throttle, brake, gear }` (the simulated higher-level computer's
movement command), `hlc_lights = { turn_left, ... }` (a LightsCommand's requests),
`hlc_control = { remote_stop, re_enable }`. Actions are listed in ACTIONS, conditions in
CONDITIONS.

`computer = "bridge"` (default "hlc") makes the ROS 2 bridge's CAN side the higher-level
computer (`sim/bridge_computer.py`), with its parameters in an optional `[bridge]` table (the
node's ROS parameters, range-checked as the node checks them). It is driven by
`planner = { speed_mps, curvature_per_m, rate_hz, stamp_lag_s, publishing }` (a simulated planner
publishing set-points) and `bridge_service = { enable = true }` or `{ remote_stop = ... }` (the
node's services); `hlc*` events then change nothing (the simulated computer is not running).
"""

from __future__ import annotations

import difflib
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import tomli_w

from bywire.config.reader import show, show_key, toml_type
from bywire.errors import ConfigError
from bywire.ros2.settings import settings_from
from bywire.sim.conditions import CONDITIONS as CONDITION_TABLE
from bywire.sim.faults import FAULTS as FAULT_TABLE
from bywire.sim.scenario_values import (
    ACTION_VALUES,
    FAULT_VALUES,
    SECONDS,
    SECONDS_TEXT,
    Check,
)
from bywire.textfile import read_text

ACTIONS = {action: set(keys) for action, keys in ACTION_VALUES.items()}
"""Every action and its keys, from the table that also checks their values."""
FAULTS = {fault.name: fault.description for fault in FAULT_TABLE}
CONDITIONS = {condition.key: condition.description for condition in CONDITION_TABLE}
CONDITION_VALUES = {condition.key: condition.check for condition in CONDITION_TABLE}
SENSORS = {
    "wheel_speed": "the wheel-speed sensors",
    "brake_pressure": "the hydraulic brake's pressure sensor",
    "steering_encoder": "the steering encoder",
}
"""The optional sensors a scenario may need (`needs_sensors`), as a sentence names them."""
EVENT_KEYS = {"at_s", "label", "fault", "count", "load", "stall_s", "line", "keyed", *ACTIONS}
EXPECT_KEYS = {"after", "within_s", "during_s", "at_s", "label", *CONDITIONS}
DEFAULT_DURATION_S = 30.0
COMPUTERS = ("hlc", "bridge")
"""Which simulated higher-level computer sends the commands: `hal.simulated.hlc`, or the bridge."""
BRIDGE_ACTIONS = frozenset({"planner", "bridge_service"})


@dataclass(frozen=True, slots=True)
class Event:
    """One timed action: `kind` is an ACTIONS key or "fault"; `values` its settings."""

    at_s: float
    kind: str
    values: dict[str, Any]
    label: str | None = None


@dataclass(frozen=True, slots=True)
class Expectation:
    """Conditions that must hold together, within `within_s` of an event or at `at_s`."""

    conditions: dict[str, Any]
    after: str | None = None
    within_s: float | None = None
    at_s: float | None = None
    label: str | None = None
    during_s: float | None = None  # hold at every pass for this long after `after`

    def describe(self) -> str:
        if self.label:
            return self.label
        if self.after is not None and self.during_s is not None:
            when = f"throughout {self.during_s * 1000:.0f} ms after '{self.after}'"
        elif self.after is not None and self.within_s is not None:
            when = f"within {self.within_s * 1000:.0f} ms of '{self.after}'"
        else:
            when = f"at {self.at_s} s"
        return f"{when}: " + ", ".join(f"{key}={value}" for key, value in self.conditions.items())


@dataclass(frozen=True, slots=True)
class Scenario:
    """A whole scenario: events sorted by time, expectations, and how long to run."""

    name: str
    description: str
    duration_s: float
    events: tuple[Event, ...]
    expectations: tuple[Expectation, ...]
    realtime: bool = False  # paced by the wall clock (what the watchdog measures)
    authenticated: bool = False  # commands signed and verified (SecOC, docs/SECURITY.md)
    needs_sensors: tuple[str, ...] = ()  # SENSORS its expectations rely on
    computer: str = "hlc"  # one of COMPUTERS
    bridge: tuple[tuple[str, Any], ...] = ()  # the bridge's parameters ([bridge]), by name


def _refuse(
    origin: str, key: str, problem: str, allowed: set[str] | None = None, given: str | None = None
) -> ConfigError:
    """The error for one bad key; `given` (default: the key's last part) is matched to `allowed`."""
    hint = ""
    if allowed is not None:
        wrong = given if given is not None else key.rsplit(".", 1)[-1]
        close = difflib.get_close_matches(wrong, sorted(allowed), n=1)
        hint = (
            f" (did you mean '{close[0]}'?)"
            if close
            else f"; allowed: {', '.join(sorted(allowed))}"
        )
    return ConfigError(f"{origin}: {key}: {problem}{hint}")


def _key(where: str, key: str) -> str:
    shown = show_key(str(key))
    return f"{where}.{shown}" if where else shown


def _check_keys(table: dict[str, Any], allowed: set[str], origin: str, where: str) -> None:
    for key in table:
        if key not in allowed:
            raise _refuse(origin, _key(where, key), "unknown key", allowed, str(key))


def _table(value: Any, origin: str, where: str, what: str) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise _refuse(origin, where, f"must be {what}, got {toml_type(value)} {show(value)}")
    return value


def _tables(document: dict[str, Any], key: str, origin: str) -> list[dict[str, Any]]:
    """`[[key]]`: an array of tables (none when absent)."""
    value = document.get(key, [])
    if not isinstance(value, list) or not all(isinstance(item, dict) for item in value):
        raise _refuse(origin, key, f"must be an array of tables ([[{key}]]), got {show(value)}")
    return value


def _time(table: dict[str, Any], key: str, origin: str, where: str) -> float:
    value = table.get(key)
    if isinstance(value, int | float) and SECONDS(value) is None:
        return float(value)
    raise _refuse(origin, _key(where, key), f"got {value!r}; allowed: {SECONDS_TEXT}")


def _text(table: dict[str, Any], key: str, origin: str, where: str) -> str | None:
    value = table.get(key)
    if value is not None and not (isinstance(value, str) and value.strip()):
        raise _refuse(origin, _key(where, key), f"must be a non-empty string, got {show(value)}")
    return value


def _event(table: dict[str, Any], origin: str, where: str) -> Event:
    _check_keys(table, EVENT_KEYS, origin, where)
    kinds = [key for key in (*ACTIONS, "fault") if key in table]
    if len(kinds) != 1:
        raise _refuse(origin, where, f"needs exactly one of {', '.join([*ACTIONS, 'fault'])}")
    kind = kinds[0]
    if kind == "fault":
        fault = table["fault"]
        if not isinstance(fault, str) or fault not in FAULTS:
            raise _refuse(
                origin, f"{where}.fault", f"unknown fault {show(fault)}", set(FAULTS), str(fault)
            )
        values = {
            "fault": fault,
            "count": table.get("count", 1),
            "load": table.get("load", 1.0),
            "stall_s": table.get("stall_s", 0.5),
            "line": table.get("line", "turn_left_light"),
            "keyed": table.get("keyed", False),
        }
        _check_values(values, FAULT_VALUES, origin, where)
    else:
        values = dict(_table(table[kind], origin, f"{where}.{kind}", "a table { key = value }"))
        _check_keys(values, ACTIONS[kind], origin, f"{where}.{kind}")
        _check_values(values, ACTION_VALUES[kind], origin, f"{where}.{kind}")
    label = _text(table, "label", origin, where)
    return Event(_time(table, "at_s", origin, where), kind, values, label)


def _check_values(table: dict[str, Any], checks: dict[str, Check], origin: str, where: str) -> None:
    for key, value in table.items():
        allowed = checks[key](value) if key in checks else None
        if allowed is not None:
            raise _refuse(origin, _key(where, key), f"got {value!r}; allowed: {allowed}")


def _expectation(table: dict[str, Any], origin: str, where: str, labels: set[str]) -> Expectation:
    _check_keys(table, EXPECT_KEYS, origin, where)
    conditions = {key: value for key, value in table.items() if key in CONDITIONS}
    if not conditions:
        raise _refuse(origin, where, "needs at least one condition", set(CONDITIONS))
    _check_values(conditions, CONDITION_VALUES, origin, where)
    label = _text(table, "label", origin, where)
    after = table.get("after")
    if after is not None:
        if not isinstance(after, str) or after not in labels:
            raise _refuse(
                origin, f"{where}.after", f"no event is labelled {show(after)}", labels, str(after)
            )
        if ("within_s" in table) == ("during_s" in table):
            raise _refuse(origin, where, "with `after`, give exactly one of within_s, during_s")
        if "during_s" in table:
            during_s = _time(table, "during_s", origin, where)
            return Expectation(conditions, after=after, during_s=during_s, label=label)
        within_s = _time(table, "within_s", origin, where)
        return Expectation(conditions, after=after, within_s=within_s, label=label)
    at_s = _time(table, "at_s", origin, where)
    return Expectation(conditions, at_s=at_s, label=label)


def parse_scenario(text: str, origin: str) -> Scenario:
    """A scenario from TOML text; ConfigError naming the key and what is allowed otherwise."""
    try:
        document = tomllib.loads(text)
    except ValueError as error:  # TOMLDecodeError, or an integer of too many digits
        raise ConfigError(f"{origin}: not valid TOML: {error}") from error
    except RecursionError:
        raise ConfigError(f"{origin}: not valid TOML: nested too deep") from None
    top_keys = {
        "name",
        "description",
        "duration_s",
        "realtime",
        "authenticated",
        "needs_sensors",
        "computer",
        "bridge",
        "event",
        "expect",
    }
    _check_keys(document, top_keys, origin, "")
    events = [
        _event(table, origin, f"event[{index}]")
        for index, table in enumerate(_tables(document, "event", origin))
    ]
    labels = {event.label for event in events if event.label}
    expectations = [
        _expectation(table, origin, f"expect[{index}]", labels)
        for index, table in enumerate(_tables(document, "expect", origin))
    ]
    duration_s = _duration(document, origin)
    _within_duration(events, expectations, duration_s, origin)
    description = document.get("description", "")
    if not isinstance(description, str):
        raise _refuse(origin, "description", f"must be a string, got {show(description)}")
    return Scenario(
        name=_text(document, "name", origin, "") or Path(origin).stem,
        description=description,
        duration_s=duration_s,
        events=tuple(sorted(events, key=lambda event: event.at_s)),
        expectations=tuple(expectations),
        realtime=_realtime(document, events, origin),
        authenticated=_authenticated(document, origin),
        needs_sensors=_needs_sensors(document, origin),
        **_computer(document, events, origin),
    )


def _computer(document: dict[str, Any], events: list[Event], origin: str) -> dict[str, Any]:
    """`computer` and `[bridge]`: the bridge's parameters checked as its node checks them, and
    planner or service events only where the bridge runs."""
    computer = document.get("computer", "hlc")
    if computer not in COMPUTERS:
        raise _refuse(origin, "computer", f"got {show(computer)}", set(COMPUTERS), str(computer))
    bridge = _table(document.get("bridge", {}), origin, "bridge", "a table of bridge parameters")
    if bridge and computer != "bridge":
        raise _refuse(origin, "bridge", 'parameters of the bridge need computer = "bridge"')
    try:
        settings_from(bridge)
    except ConfigError as error:
        raise _refuse(origin, "bridge", str(error)) from None
    for index, event in enumerate(events):
        if event.kind in BRIDGE_ACTIONS and computer != "bridge":
            raise _refuse(origin, f"event[{index}].{event.kind}", 'needs computer = "bridge"')
    parameters = {k: tuple(v) if isinstance(v, list) else v for k, v in bridge.items()}
    return {"computer": computer, "bridge": tuple(sorted(parameters.items()))}


def _needs_sensors(document: dict[str, Any], origin: str) -> tuple[str, ...]:
    names = document.get("needs_sensors", [])
    if not isinstance(names, list):
        raise _refuse(origin, "needs_sensors", f"must be a list of sensor names, got {names!r}")
    for name in names:
        if not isinstance(name, str) or name not in SENSORS:
            raise _refuse(
                origin, "needs_sensors", f"unknown sensor {name!r}", set(SENSORS), str(name)
            )
    return tuple(names)


def _duration(document: dict[str, Any], origin: str) -> float:
    if "duration_s" not in document:
        return DEFAULT_DURATION_S
    duration_s = _time(document, "duration_s", origin, "")
    if duration_s <= 0:
        raise _refuse(origin, "duration_s", f"got {show(duration_s)}; allowed: {SECONDS_TEXT} > 0")
    return duration_s


def _authenticated(document: dict[str, Any], origin: str) -> bool:
    authenticated = document.get("authenticated", False)
    if not isinstance(authenticated, bool):
        raise _refuse(origin, "authenticated", f"must be true or false, got {show(authenticated)}")
    return authenticated


def _within_duration(
    events: list[Event], expectations: list[Expectation], duration_s: float, origin: str
) -> None:
    """An event or a timed expectation after the end would silently never happen."""
    late = [(f"event[{i}].at_s", e.at_s) for i, e in enumerate(events) if e.at_s > duration_s]
    late += [
        (f"expect[{i}].at_s", e.at_s)
        for i, e in enumerate(expectations)
        if e.at_s is not None and e.at_s > duration_s
    ]
    if late:
        key, at_s = late[0]
        raise _refuse(
            origin,
            key,
            f"{at_s:g} s is after the end of the scenario (duration_s = {duration_s:g}):"
            " it would never happen; raise duration_s or move it",
        )


def _realtime(document: dict[str, Any], events: list[Event], origin: str) -> bool:
    realtime = document.get("realtime", False)
    if not isinstance(realtime, bool):
        raise _refuse(origin, "realtime", f"must be true or false, got {show(realtime)}")
    if not realtime and any(event.values.get("fault") == "loop_stall" for event in events):
        raise _refuse(origin, "realtime", "a loop_stall needs realtime = true")
    return realtime


def scenario_toml(scenario: Scenario, header: str = "") -> str:
    """The TOML text `parse_scenario` reads back as `scenario` (`header`: comment lines)."""
    events = []
    for event in scenario.events:
        table: dict[str, Any] = {"at_s": event.at_s}
        if event.label:
            table["label"] = event.label
        if event.kind == "fault":
            table.update((k, v) for k, v in event.values.items() if k in _FAULT_VALUE_KEYS)
        else:
            table[event.kind] = dict(event.values)
        events.append(table)
    expectations = []
    for expectation in scenario.expectations:
        timing = {
            key: value
            for key, value in (
                ("after", expectation.after),
                ("within_s", expectation.within_s),
                ("during_s", expectation.during_s),
                ("at_s", expectation.at_s),
                ("label", expectation.label),
            )
            if value is not None
        }
        expectations.append({**timing, **expectation.conditions})
    document: dict[str, Any] = {
        "name": scenario.name,
        "description": scenario.description,
        "duration_s": scenario.duration_s,
    }
    if scenario.realtime:
        document["realtime"] = True
    if scenario.authenticated:
        document["authenticated"] = True
    if scenario.needs_sensors:
        document["needs_sensors"] = list(scenario.needs_sensors)
    if scenario.computer != "hlc":
        document["computer"] = scenario.computer
    if scenario.bridge:
        document["bridge"] = {key: _plain(value) for key, value in scenario.bridge}
    document.update(event=events, expect=expectations)
    comments = "".join(f"# {line}\n" if line else "#\n" for line in header.splitlines())
    return comments + tomli_w.dumps(document)


_FAULT_VALUE_KEYS = ("fault", "count", "load", "stall_s", "line", "keyed")


def _plain(value: Any) -> Any:
    """A parameter as TOML writes it (a map's tuple as an array)."""
    return list(value) if isinstance(value, tuple) else value


def load_scenario(path: Path) -> Scenario:
    """Read and parse a scenario file; ConfigError (one line) naming the path if it cannot be
    read: missing, not a regular file (a FIFO, a device), too large, or not UTF-8."""
    return parse_scenario(read_text(path, "scenario file"), str(path))
