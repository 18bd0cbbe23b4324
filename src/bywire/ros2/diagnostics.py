"""The content of `/diagnostics`: one status per subsystem, built from the robot's reports and the
bridge's own counts. Pure and ROS-free (the node copies it into `diagnostic_msgs`; the rosbag2
export writes the same content).

Subsystems: the robot's mode (mode, arming, the latched stop causes by flag name), one per group
of error flags (every flag belongs to exactly one `FLAG_GROUPS` entry: a test holds them to
`ErrorFlag`), the CAN link (bus state, frames, send errors, report age) and the inputs (the
planner's command ages, refusals, the controller's own input ages from its status report).
Levels follow diagnostic_msgs: OK, WARN, ERROR, STALE (nothing heard).
"""

from __future__ import annotations

import enum
import functools
import operator
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

from bywire.error_flags import SUBSYSTEMS, ErrorFlag, Subsystem, flag_names
from bywire.model import StatusReport
from bywire.ros2.robot import LATCH_FLAGS, RobotStatus
from bywire.ros2.setpoint import Refusal, Tally

PREFIX = "bywire: "
RECENT_S = 5.0  # a refusal this recent makes the inputs' status a warning
REFUSING_S = 1.0  # commands arriving and every one refused this long: the inputs' status an error
LATE_PERIOD_S = 0.05  # a period this long (20 ms nominal) eats half the robot's CAN timeout
HARDWARE_ID = "bywire"


class Level(enum.IntEnum):
    """diagnostic_msgs/DiagnosticStatus levels."""

    OK = 0
    WARN = 1
    ERROR = 2
    STALE = 3


@dataclass(frozen=True, slots=True)
class Status:
    """One DiagnosticStatus: its name, level, one-line message and key/value pairs."""

    name: str
    level: Level
    message: str
    values: tuple[tuple[str, str], ...] = ()


FLAG_GROUPS: dict[str, ErrorFlag] = {
    subsystem.value: functools.reduce(
        operator.or_,
        (flag for flag, owner in SUBSYSTEMS.items() if owner is subsystem),
        ErrorFlag(0),
    )
    for subsystem in Subsystem
}
"""The error flags by subsystem: one status each."""


@dataclass(frozen=True, slots=True)
class LinkHealth:
    """The bridge's side of the bus and its inputs (all counts since start)."""

    bus: str = "unknown"  # python-can's state name, or why the bus is down
    frames_sent: int = 0
    send_errors: int = 0
    frames_received: int = 0
    bad_frames: int = 0
    max_period_s: float = 0.0  # the longest time between two sending periods (a starved link)
    command_age_s: float | None = None  # the newest set-point, by arrival
    stamp_age_s: float | None = None  # the newest set-point, by header stamp
    refused: int = 0  # set-points refused (`setpoint.Tally`: at arrival, aged out while held)
    last_refusal: str = ""
    last_refusal_age_s: float | None = None
    activity: str = ""
    refused_by_reason: tuple[tuple[str, int], ...] = ()  # (Refusal's name, count), each reason
    accepted_age_s: float | None = None  # since a command was last replaced while usable
    arrival_age_s: float | None = None  # since the newest command arrived
    refusing_for_s: float | None = None  # since the first refusal after the last acceptance


def with_tally(health: LinkHealth, tally: Tally, now_s: float) -> LinkHealth:
    """`health` with the commands' fates from `tally` at `now_s`."""

    def age(at_s: float | None) -> float | None:
        return None if at_s is None else now_s - at_s

    refusal = tally.last_refusal
    return replace(
        health,
        refused=tally.total_refused,
        last_refusal="" if refusal is None else refusal.value,
        last_refusal_age_s=age(tally.refused_at_s),
        refused_by_reason=tuple((r.name, n) for r, n in zip(Refusal, tally.refused, strict=True)),
        accepted_age_s=age(tally.accepted_at_s),
        arrival_age_s=age(tally.arrived_at_s),
        refusing_for_s=age(tally.refusing_since_s),
    )


def _age(seconds: float | None) -> str:
    return "never" if seconds is None else f"{seconds:.3f}"


def mode_line(status: RobotStatus, engaged: bool) -> str:
    """`~/mode`: the control mode, then arming, enabling and the latched causes, e.g.
    "CAN armed enabled", "STOP latched REMOTE_STOP", "UNKNOWN no reports"."""
    if not status.reporting or status.mode is None:
        return "UNKNOWN no reports"
    words = [status.mode.name]
    words += ["armed"] if status.armed else []
    words += ["enabled"] if engaged and status.drivable else []
    causes = status.latched_causes
    words += ["latched", *causes] if causes else []
    return " ".join(words)


def mode_status(status: RobotStatus, engaged: bool, remote_stop: bool) -> Status:
    """The robot's mode, its arming, and the latched stop causes by name."""
    if not status.reporting:
        return Status(PREFIX + "mode", Level.STALE, "no reports from the robot")
    causes = status.latched_causes
    mode = "none" if status.mode is None else status.mode.name
    values = (
        ("control_mode", mode),
        ("stop_latched", str(status.latched).lower()),
        ("latched_causes", " ".join(causes)),
        ("armed", str(status.armed).lower()),
        ("bridge_enabled", str(engaged).lower()),
        ("remote_stop_requested", str(remote_stop).lower()),
        ("speed_limited", str(status.speed_limited).lower()),
    )
    if causes:
        return Status(PREFIX + "mode", Level.ERROR, f"STOP latched: {' '.join(causes)}", values)
    if not status.speed_trusted:
        if status.flags & ErrorFlag.SPEED_SENSOR_FAULT:
            why = "SPEED_SENSOR_FAULT"
        elif not status.speed_measured:
            why = "the robot measures no wheel speed"
        else:
            why = "no recent ErrorReport"
        message = f"speed unknown ({why}): the bridge asks no throttle and brakes to a stop"
        return Status(PREFIX + "mode", Level.ERROR, message, values)
    if status.drivable and engaged:
        limited = ", held to the robot's speed limit" if status.speed_limited else ""
        return Status(PREFIX + "mode", Level.OK, f"CAN mode, enabled{limited}", values)
    hint = "call ~/enable" if status.drivable else f"{mode} mode"
    return Status(PREFIX + "mode", Level.WARN, f"not driving: {hint}", values)


def flag_statuses(status: RobotStatus) -> list[Status]:
    """One status per flag group: ERROR for a latched cause, WARN for any other flag up."""
    statuses = []
    for group, members in FLAG_GROUPS.items():
        name = PREFIX + group
        if not status.reporting:
            statuses.append(Status(name, Level.STALE, "no reports from the robot"))
            continue
        up = status.flags & members
        latched = [flag for flag in LATCH_FLAGS if up & flag] if status.latched else []
        level = Level.ERROR if latched else Level.WARN if up else Level.OK
        names = flag_names(up)
        values = tuple((flag, "latched" if ErrorFlag[flag] in latched else "up") for flag in names)
        statuses.append(Status(name, level, " ".join(names) or "OK", values))
    return statuses


def link_status(health: LinkHealth, status: RobotStatus) -> Status:
    """The CAN link from this computer: bus state, traffic, send errors, report age."""
    values = (
        ("bus_state", health.bus),
        ("frames_sent", str(health.frames_sent)),
        ("send_errors", str(health.send_errors)),
        ("frames_received", str(health.frames_received)),
        ("bad_frames", str(health.bad_frames)),
        ("max_period_s", f"{health.max_period_s:.3f}"),
        ("report_age_s", _age(status.report_age_s)),
    )
    name = PREFIX + "CAN link"
    if health.bus not in {"active", "unknown"}:
        return Status(name, Level.ERROR, f"bus {health.bus}", values)
    if not status.reporting:
        return Status(name, Level.ERROR, "no reports from the robot", values)
    if health.send_errors:
        return Status(name, Level.WARN, f"{health.send_errors} send errors", values)
    if health.max_period_s > LATE_PERIOD_S:
        late = f"a sending period took {health.max_period_s:.3f} s: this computer starves the link"
        return Status(name, Level.WARN, late, values)
    return Status(name, Level.OK, "reports arriving, commands sent", values)


def inputs_status(health: LinkHealth, robot_status_report: StatusReport | None) -> Status:
    """The planner's command ages and refusals, and the controller's own input ages."""
    values: list[tuple[str, str]] = [
        ("command_age_s", _age(health.command_age_s)),
        ("command_stamp_age_s", _age(health.stamp_age_s)),
        ("commands_refused", str(health.refused)),
        *((f"refused_{name.lower()}", str(count)) for name, count in health.refused_by_reason),
        ("last_refusal", health.last_refusal),
        ("last_refusal_age_s", _age(health.last_refusal_age_s)),
        ("last_accepted_age_s", _age(health.accepted_age_s)),
        ("activity", health.activity),
    ]
    if robot_status_report is not None:
        values += [
            ("robot_can_command_age_ms", str(robot_status_report.can_command_age_ms)),
            ("robot_rc_input_age_ms", str(robot_status_report.rc_input_age_ms)),
            ("robot_uptime_s", str(robot_status_report.uptime_s)),
            ("robot_task_overruns", str(robot_status_report.overrun_count)),
        ]
    name = PREFIX + "inputs"
    if refusing(health):
        message = (
            f"every command refused for {health.refusing_for_s:.1f} s while they keep arriving:"
            f" {health.last_refusal}"
        )
        return Status(name, Level.ERROR, message, tuple(values))
    recent = health.last_refusal_age_s is not None and health.last_refusal_age_s < RECENT_S
    if recent:
        return Status(name, Level.WARN, f"refused: {health.last_refusal}", tuple(values))
    return Status(name, Level.OK, health.activity or "OK", tuple(values))


def refusing(health: LinkHealth) -> bool:
    """Commands keep arriving (the newest within `REFUSING_S`) and none has been accepted
    since the first refusal, `REFUSING_S` or more ago: the planner cannot drive the robot."""
    arriving = health.arrival_age_s is not None and health.arrival_age_s <= REFUSING_S
    return arriving and health.refusing_for_s is not None and health.refusing_for_s >= REFUSING_S


LOGGED = (PREFIX + "mode", PREFIX + "inputs")
"""The statuses whose every change of level is logged (one line per change, not per command)."""


def log_lines(
    before: Mapping[str, Level], now: Sequence[Status]
) -> tuple[dict[str, Level], list[tuple[Level, str]]]:
    """The levels of `LOGGED` in `now`, and one line (with its level) for each that changed
    since `before` (a first OK is not news)."""
    levels = {status.name: status.level for status in now if status.name in LOGGED}
    lines = [
        (status.level, f"{status.name} {status.level.name}: {status.message}")
        for status in now
        if status.name in levels and before.get(status.name, Level.OK) is not status.level
    ]
    return levels, lines


def statuses(
    status: RobotStatus,
    health: LinkHealth,
    robot_status_report: StatusReport | None,
    *,
    engaged: bool,
    remote_stop: bool,
) -> list[Status]:
    """Every status of one DiagnosticArray."""
    return [
        mode_status(status, engaged, remote_stop),
        *flag_statuses(status),
        link_status(health, status),
        inputs_status(health, robot_status_report),
    ]
