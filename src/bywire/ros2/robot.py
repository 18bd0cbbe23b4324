"""What the bridge knows of the robot: its reports folded with their arrival times (the teleop's
`ReportView`), read as one status, and why it is not armed when it is not."""

from __future__ import annotations

from dataclasses import dataclass

from bywire.control.supervisor import CAN_CLEARABLE, CAUSE_FLAGS
from bywire.error_flags import ErrorFlag, flag_names
from bywire.model import ControlMode, ErrorReport, Gear, ModeReport, WheelSpeedReport
from bywire.teleop.reports import ReportView

NO_FLAGS = ErrorFlag(0)
LATCH_FLAGS = frozenset(CAUSE_FLAGS.values())
"""Every flag that names a latched cause while STOP is latched."""
CAN_CLEARABLE_FLAGS = frozenset(CAUSE_FLAGS[cause] for cause in CAN_CLEARABLE)
"""The latched causes a re-enable edge over CAN may clear; the others need the transmitter."""


@dataclass(frozen=True, slots=True)
class RobotStatus:
    """The robot at one instant, as its reports say; `reporting` is False when the mode or wheel
    speed report is missing or older than `report_timeout_s` (then nothing else may be trusted)."""

    reporting: bool
    report_age_s: float | None
    mode: ControlMode | None = None
    latched: bool = False
    armed: bool = False
    gear: Gear = Gear.NEUTRAL  # as the controller applies it (its interlocks may hold it back)
    speed_mps: float = 0.0  # the report's figure; means nothing unless `speed_trusted`
    flags: ErrorFlag = NO_FLAGS
    speed_trusted: bool = False
    speed_measured: bool = False  # the WheelSpeedReport's measured_valid
    speed_limited: bool = False  # the WheelSpeedReport's speed_limited: the robot's governor acts

    @property
    def trusted_speed_mps(self) -> float | None:
        """The reported speed (signed, forward positive) when it is trusted, else None."""
        return self.speed_mps if self.speed_trusted else None

    @property
    def drivable(self) -> bool:
        """In CAN mode, not latched, and heard from: movement commands drive it."""
        return self.reporting and self.mode is ControlMode.CAN and not self.latched

    @property
    def latched_causes(self) -> list[str]:
        """The flags naming why STOP is latched (empty when it is not)."""
        if not self.latched:
            return []
        causes = NO_FLAGS
        for flag in LATCH_FLAGS:
            causes |= self.flags & flag
        return flag_names(causes)


def robot_status(view: ReportView, now_s: float, report_timeout_s: float) -> RobotStatus:
    """The status from the newest reports at `now_s` (the arrival clock)."""
    ages = [view.age_s(kind, now_s) for kind in (ModeReport, WheelSpeedReport)]
    known = [age for age in ages if age is not None]
    age_s = max(known) if len(known) == len(ages) else None
    mode, wheels = view.get(ModeReport), view.get(WheelSpeedReport)
    if mode is None or wheels is None or age_s is None:
        return RobotStatus(reporting=False, report_age_s=age_s)
    errors = view.get(ErrorReport)
    reporting = age_s <= report_timeout_s
    errors_age_s = view.age_s(ErrorReport, now_s)
    flags_known = errors_age_s is not None and errors_age_s <= report_timeout_s
    flags = NO_FLAGS if errors is None else errors.flags
    return RobotStatus(
        reporting=reporting,
        report_age_s=age_s,
        mode=mode.control_mode,
        latched=mode.stop_latched,
        armed=mode.armed,
        gear=mode.gear,
        speed_mps=(wheels.left_mps + wheels.right_mps) / 2,
        flags=flags,
        speed_measured=wheels.measured_valid,
        speed_limited=wheels.speed_limited,
        speed_trusted=(
            reporting
            and wheels.measured_valid  # no sensor, or no reading: unknown, never standstill
            and flags_known
            and not flags & ErrorFlag.SPEED_SENSOR_FAULT
        ),
    )


def why_not_armed(status: RobotStatus) -> str:
    """One sentence: why the robot does not take movement commands, and what to do."""
    if not status.reporting:
        seen = "never" if status.report_age_s is None else f"{status.report_age_s:.2f} s ago"
        return (
            f"no reports from the robot (last {seen}): is bywire running on it, and this"
            " computer on its bus?"
        )
    if status.mode is ControlMode.RC:
        return "the RC transmitter selects RC mode: set its mode switch to CAN"
    causes = status.latched_causes
    if causes:
        held = [name for name in causes if ErrorFlag[name] not in CAN_CLEARABLE_FLAGS]
        if held:
            return (
                f"STOP latched by {', '.join(causes)}; {', '.join(held)} is cleared on the"
                " transmitter only: move its mode switch through STOP, then to CAN"
            )
        return f"STOP latched by {', '.join(causes)}, and the re-enable did not clear it"
    if status.mode is ControlMode.STOP:
        return "the robot is in STOP: set the transmitter's mode switch to CAN"
    return "the robot is in CAN mode but not armed"
