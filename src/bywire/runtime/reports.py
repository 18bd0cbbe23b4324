"""The 50 Hz reports to the higher-level computer, built from one control step's outputs, and the
last ones a loop that ended by a task raising sends (TASK_CRASHED)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from bywire.control.controller import ControlOutputs
from bywire.error_flags import ErrorFlag
from bywire.model import (
    ControlMode,
    ErrorReport,
    Gear,
    LightsReport,
    ModeReport,
    Report,
    StatusReport,
    SteeringReport,
    WheelSpeedReport,
)

NEVER_SEEN_MS = 4095  # the StatusReport's "never received" value


@dataclass(frozen=True, slots=True)
class Health:
    """What the status report says about the controller itself."""

    uptime_s: float
    overrun_count: int
    rc_age_s: float | None
    can_age_s: float | None
    wheel_speeds_mps: tuple[float, float] | None
    steering_setpoint_norm: float
    steering_measured_norm: float | None = None  # None without a steering encoder
    encoder_valid_limit_norm: float = 1.2  # a reading beyond this is invalid (monitors)

    def __init__(  # noqa: PLR0917
        self,
        uptime_s: float,
        overrun_count: int,
        rc_age_s: float | None,
        can_age_s: float | None,
        wheel_speeds_mps: tuple[float, float] | None,
        steering_setpoint_norm: float,
        steering_measured_norm: float | None = None,
        encoder_valid_limit_norm: float = 1.2,
    ) -> None:
        object.__setattr__(self, "uptime_s", uptime_s)
        object.__setattr__(self, "overrun_count", overrun_count)
        object.__setattr__(self, "rc_age_s", rc_age_s)
        object.__setattr__(self, "can_age_s", can_age_s)
        object.__setattr__(self, "wheel_speeds_mps", wheel_speeds_mps)
        object.__setattr__(self, "steering_setpoint_norm", steering_setpoint_norm)
        object.__setattr__(self, "steering_measured_norm", steering_measured_norm)
        object.__setattr__(self, "encoder_valid_limit_norm", encoder_valid_limit_norm)

    @property
    def steering_measured(self) -> float | None:
        """The encoder's reading when one is fitted and it is a valid angle, else None."""
        measured = self.steering_measured_norm
        valid = measured is not None and abs(measured) <= self.encoder_valid_limit_norm
        return measured if valid else None


def _age_ms(age_s: float | None) -> int:
    return NEVER_SEEN_MS if age_s is None else min(max(round(age_s * 1000), 0), NEVER_SEEN_MS)


def build_reports(outputs: ControlOutputs, health: Health) -> tuple[Report, ...]:
    """Reports in priority order: safety state first, then data."""
    request = outputs.light_request
    wheels = health.wheel_speeds_mps  # None: no sensor fitted, or it gave no reading
    wheels_valid = wheels is not None and all(math.isfinite(speed) for speed in wheels)
    left_mps, right_mps = wheels if wheels is not None and wheels_valid else (0.0, 0.0)
    measured = health.steering_measured
    return (
        ModeReport(
            gear=outputs.movement.gear,
            control_mode=outputs.mode,
            estop_engaged=outputs.ebrake_engaged,
            stop_latched=bool(outputs.causes),
            armed=not outputs.causes,
        ),
        ErrorReport(flags=ErrorFlag(outputs.error_flags)),
        WheelSpeedReport(
            left_mps=left_mps,
            right_mps=right_mps,
            measured_valid=wheels_valid,
            speed_limited=outputs.speed_limited,
        ),
        SteeringReport(
            commanded_norm=health.steering_setpoint_norm,
            measured_norm=0.0 if measured is None else measured,
            measured_valid=measured is not None,
        ),
        LightsReport(
            brake=outputs.lights.brake,
            reverse=outputs.lights.reverse,
            turn_left=request.turn_left or request.hazard,
            turn_right=request.turn_right or request.hazard,
            hazard=request.hazard,
            low_beam=outputs.lights.low_beam,
            error_led=outputs.lights.error_led,
        ),
        StatusReport(
            uptime_s=int(health.uptime_s),
            overrun_count=health.overrun_count,
            rc_input_age_ms=_age_ms(health.rc_age_s),
            can_command_age_ms=_age_ms(health.can_age_s),
        ),
    )


def crash_reports(last: ControlOutputs | None) -> tuple[Report, ...]:
    """What a loop that a task's exception ended says last, once its outputs are safe: STOP with
    the e-brake engaged, latched and not armed (the restarted process starts in STOP), neutral
    (both direction lines are low), and the `last` decision's flags with TASK_CRASHED."""
    flags = ErrorFlag.TASK_CRASHED | (0 if last is None else last.error_flags)
    return (
        ModeReport(Gear.NEUTRAL, ControlMode.STOP, True, stop_latched=True, armed=False),
        ErrorReport(flags=ErrorFlag(flags)),
    )
