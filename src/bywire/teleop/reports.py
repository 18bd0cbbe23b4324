"""What the teleop shows of the robot: decoded reports folded into one view, rendered as lines.

Pure: ``fold`` takes the arrival time, ``lines`` the current time, so ages are exact in tests.
Frames that are not reports (our own commands echoed, other nodes) are counted and ignored.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import TypeVar

from bywire.error_flags import flag_names
from bywire.errors import FrameError
from bywire.model import (
    ControlMode,
    ErrorReport,
    LightsReport,
    ModeReport,
    Report,
    StatusReport,
    SteeringReport,
    WheelSpeedReport,
)
from bywire.protocol import dbc
from bywire.security.session import SecocSigner
from bywire.teleop.state import TeleopState

NEVER = "—"
NO_READING = "no reading"  # a WheelSpeedReport that says the robot measures no speed
MPS_TO_KMH = 3.6

_R = TypeVar("_R", bound=Report)


@dataclass(frozen=True, slots=True)
class ReportView:
    """The newest report of each type with its arrival time, and the count of undecodable frames."""

    latest: dict[type[object], tuple[float, Report]] = field(default_factory=dict)
    bad_frames: int = 0

    def get(self, kind: type[_R]) -> _R | None:
        """The newest report of ``kind``, None before the first."""
        entry = self.latest.get(kind)
        return None if entry is None or not isinstance(entry[1], kind) else entry[1]

    def age_s(self, kind: type[object], now_s: float) -> float | None:
        """Seconds since the newest report of ``kind`` arrived, None before the first."""
        entry = self.latest.get(kind)
        return None if entry is None else now_s - entry[0]


def fold(view: ReportView, frame_id: int, data: bytes, received_at_s: float) -> ReportView:
    """The view with one received frame applied; non-report frames leave it unchanged."""
    if frame_id not in dbc.report_ids():
        return view
    try:
        report = dbc.decode_report(frame_id, data)
    except FrameError:
        return replace(view, bad_frames=view.bad_frames + 1)
    return replace(view, latest={**view.latest, type(report): (received_at_s, report)})


def speed_mps(view: ReportView) -> float | None:
    """The robot's speed: the mean of the two wheel speeds, None before the first report and
    while the robot measures none (no wheel sensor, or no reading: unknown, never standstill)."""
    wheels = view.get(WheelSpeedReport)
    if wheels is None or not wheels.measured_valid:
        return None
    return (wheels.left_mps + wheels.right_mps) / 2


def _on(names: dict[str, bool]) -> str:
    active = [name for name, value in names.items() if value]
    return " ".join(active) if active else "off"


def _mode_line(view: ReportView) -> str:
    mode = view.get(ModeReport)
    if mode is None:
        return f"mode {NEVER}"
    state = _on({"armed": mode.armed, "LATCHED": mode.stop_latched, "E-STOP": mode.estop_engaged})
    return f"mode {mode.control_mode.name}  gear {mode.gear.name}  {state}"


def _motion_line(view: ReportView) -> str:
    speed = speed_mps(view)
    if view.get(WheelSpeedReport) is None:
        speed_text = NEVER
    elif speed is None:
        speed_text = NO_READING
    else:
        speed_text = f"{speed:+.2f} m/s ({speed * MPS_TO_KMH:+.1f} km/h)"
    steering = view.get(SteeringReport)
    steer_text = NEVER if steering is None else f"{steering.commanded_norm:+.2f}"
    if steering is not None and steering.measured_valid:
        steer_text += f" (measured {steering.measured_norm:+.2f})"
    return f"speed {speed_text}  steering {steer_text}"


def _lights_line(view: ReportView) -> str:
    lights = view.get(LightsReport)
    if lights is None:
        return f"lights {NEVER}"
    return "lights " + _on(
        {
            "brake": lights.brake,
            "reverse": lights.reverse,
            "left": lights.turn_left,
            "right": lights.turn_right,
            "hazard": lights.hazard,
            "low-beam": lights.low_beam,
            "error-led": lights.error_led,
        }
    )


def _errors_line(view: ReportView) -> str:
    errors = view.get(ErrorReport)
    if errors is None:
        return f"errors {NEVER}"
    return "errors " + (" ".join(flag_names(errors.flags)) or "none")


def _status_line(view: ReportView) -> str:
    status = view.get(StatusReport)
    if status is None:
        return f"status {NEVER}"
    return (
        f"status uptime {status.uptime_s} s  overruns {status.overrun_count}"
        f"  rc age {status.rc_input_age_ms} ms  can age {status.can_command_age_ms} ms"
    )


def _ages_line(view: ReportView, now_s: float) -> str:
    kinds = (ModeReport, ErrorReport, WheelSpeedReport, SteeringReport, LightsReport, StatusReport)
    parts = []
    for kind in kinds:
        age_s = view.age_s(kind, now_s)
        label = kind.__name__.removesuffix("Report").lower()
        parts.append(f"{label} {NEVER if age_s is None else f'{age_s * 1000:.0f} ms'}")
    return "report ages " + "  ".join(parts) + f"  bad frames {view.bad_frames}"


def stop_causes(view: ReportView) -> str | None:
    """Why the robot is in STOP, from its reports: the error flags it sends (the latched causes
    among them), or None while it is not in STOP."""
    mode, errors = view.get(ModeReport), view.get(ErrorReport)
    if mode is None or mode.control_mode is not ControlMode.STOP:
        return None
    names = [] if errors is None else flag_names(errors.flags)
    latched = "latched" if mode.stop_latched else "not latched"
    return f"robot in STOP ({latched}): " + (", ".join(names) or "no flag set (mode switch)")


def report_lines(view: ReportView, now_s: float) -> list[str]:
    """The robot's side of the status panel."""
    causes = stop_causes(view)
    return [
        _mode_line(view),
        *([] if causes is None else [causes]),
        _motion_line(view),
        _lights_line(view),
        _errors_line(view),
        _status_line(view),
        _ages_line(view, now_s),
    ]


def command_lines(state: TeleopState) -> list[str]:
    """The teleop's side: what goes out every period."""
    lights = _on(
        {
            "left": state.turn_left,
            "right": state.turn_right,
            "hazard": state.hazard,
            "low-beam": state.low_beam,
        }
    )
    control = _on({"REMOTE-STOP": state.remote_stop, "re-enable": state.re_enable})
    return [
        f"sending steering {state.steering_norm:+.2f}  throttle {state.throttle_norm:.2f}"
        f"  brake {state.brake_norm:.2f}  gear {state.gear.name}",
        f"sending lights {lights}  control {control}",
    ]


def signing_line(signer: SecocSigner, problem: str | None = None) -> str:
    """What the signer of authenticated commands is doing, in one line."""
    if problem is not None:
        return f"SecOC: not signing: {problem}"
    if signer.refused_trip is not None:
        return (
            f"SecOC: not signing: the robot announced trip {signer.refused_trip}, below trip"
            f" {signer.store.trip} this sender used: a replayed announcement, or the robot's"
            f" freshness file was rolled back (on the robot: bywire keys reset-freshness --trip"
            f" {signer.store.trip})"
        )
    if signer.trip is None and signer.announced_key_check is not None:
        return (
            f"SecOC: not signing: the robot's key check value is {signer.announced_key_check},"
            " this key's is another: give the robot's key (--key)"
        )
    if signer.trip is None:
        return "SecOC: waiting for the robot's trip counter (authentication must be on there)"
    return f"SecOC: signing in trip {signer.trip}"
