"""Monitors of the optional feedback sensors against the command (R-MONITORS, Table 4); pure.

`monitor_step` raises two flags, each clear again as soon as its condition is gone:

- HYDRO_PRESSURE_FAULT: the commanded hydraulic duty is ≥ `hydro_min_duty` and the measured
  pressure is below `hydro_bar_at_full_duty × duty` (or not finite), both continuously for longer
  than `hydro_response_s`. The pressure is allowed that long to build after the duty rises.
- STEERING_ENCODER_FAULT: at once when the encoder reading is invalid (NaN, or outside
  ±`encoder_valid_limit_norm`); or when the reading is more than `steering_tolerance_norm` off the
  command (clamped as the servo gets it) for longer than `steering_margin_s` while a model of the
  slowest acceptable servo is within tolerance. The model turns at `servo_speed_norm_per_s`
  towards the previous command and jumps to the reading whenever the real servo is ahead of it,
  so a stuck servo is flagged after its travel time plus the margin, and a servo at least as fast
  as the model never is.

A sensor that is absent (None) is not checked and never raises; its monitor starts afresh when it
appears. Which flags demand STOP is configuration (`stop_flags`, default: both, as Table 4 says).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from bywire.control.interlocks import elapsed_since
from bywire.control.steering import clamp_norm, step_towards
from bywire.control.values import slot_init
from bywire.error_flags import ErrorFlag

NO_FLAGS = ErrorFlag(0)


@dataclass(frozen=True, slots=True)
class MonitorConfig:
    """Thresholds of the monitors; times and tolerances must be finite and ≥ 0, speeds > 0."""

    hydro_min_duty: float = 0.2
    hydro_response_s: float = 0.3
    hydro_bar_at_full_duty: float = 5.0
    steering_tolerance_norm: float = 0.15
    servo_speed_norm_per_s: float = 1.5
    steering_margin_s: float = 0.2
    encoder_valid_limit_norm: float = 1.2
    stop_flags: ErrorFlag = ErrorFlag.HYDRO_PRESSURE_FAULT | ErrorFlag.STEERING_ENCODER_FAULT

    def __post_init__(self) -> None:
        limits = (
            self.hydro_min_duty,
            self.hydro_response_s,
            self.hydro_bar_at_full_duty,
            self.steering_tolerance_norm,
            self.steering_margin_s,
            self.encoder_valid_limit_norm,
        )
        if not all(math.isfinite(value) and value >= 0.0 for value in limits):
            raise ValueError("monitor thresholds must be finite and >= 0")
        if not (math.isfinite(self.servo_speed_norm_per_s) and self.servo_speed_norm_per_s > 0.0):
            raise ValueError("servo_speed_norm_per_s must be finite and > 0")


DEFAULT_MONITOR_CONFIG = MonitorConfig()


@dataclass(frozen=True, slots=True)
class MonitorInputs:
    """The command and the optional measurements at one instant; None means no sensor."""

    hydro_duty: float = 0.0
    pressure_bar: float | None = None
    steering_command_norm: float = 0.0
    steering_measured_norm: float | None = None

    def __init__(
        self,
        hydro_duty: float = 0.0,
        pressure_bar: float | None = None,
        steering_command_norm: float = 0.0,
        steering_measured_norm: float | None = None,
    ) -> None:
        object.__setattr__(self, "hydro_duty", hydro_duty)
        object.__setattr__(self, "pressure_bar", pressure_bar)
        object.__setattr__(self, "steering_command_norm", steering_command_norm)
        object.__setattr__(self, "steering_measured_norm", steering_measured_norm)


slot_init(MonitorInputs)


@dataclass(frozen=True, slots=True)
class MonitorState:
    """Since when each condition holds, and the slow-servo model of the encoder monitor.

    `servo_model_norm` is where the slowest acceptable servo would be at worst, `servo_target_norm`
    the command it was turning towards during the last interval.
    """

    pressure_low_since: float | None = None
    steering_late_since: float | None = None
    servo_model_norm: float | None = None
    servo_target_norm: float | None = None
    updated_at: float | None = None

    def __init__(
        self,
        pressure_low_since: float | None = None,
        steering_late_since: float | None = None,
        servo_model_norm: float | None = None,
        servo_target_norm: float | None = None,
        updated_at: float | None = None,
    ) -> None:
        object.__setattr__(self, "pressure_low_since", pressure_low_since)
        object.__setattr__(self, "steering_late_since", steering_late_since)
        object.__setattr__(self, "servo_model_norm", servo_model_norm)
        object.__setattr__(self, "servo_target_norm", servo_target_norm)
        object.__setattr__(self, "updated_at", updated_at)


slot_init(MonitorState)


def _since(since: float | None, condition: bool, now: float) -> float | None:
    return (now if since is None else since) if condition else None


def _lasted(since: float | None, now: float, limit_s: float) -> bool:
    return since is not None and now - since > limit_s


def _pressure_low(inputs: MonitorInputs, config: MonitorConfig) -> bool:
    """Braking hard enough to expect pressure, and the sensor shows less (or nonsense)."""
    pressure_bar = inputs.pressure_bar
    if pressure_bar is None or not inputs.hydro_duty >= config.hydro_min_duty:
        return False
    expected_bar = config.hydro_bar_at_full_duty * inputs.hydro_duty
    return not (math.isfinite(pressure_bar) and pressure_bar >= expected_bar)


def _servo_model(
    state: MonitorState,
    measured_norm: float,
    command_norm: float,
    now: float,
    config: MonitorConfig,
) -> float:
    """Advance the slow servo towards its last target; the encoder pulls it along when ahead.

    Ahead means strictly closer to the last target or to the new command: a servo at least as
    fast as the model then always pulls it, so the model never leaves it behind.
    """
    target = state.servo_target_norm
    if state.servo_model_norm is None or target is None:
        return measured_norm
    elapsed_s = elapsed_since(state.updated_at, now)
    model = step_towards(state.servo_model_norm, target, config.servo_speed_norm_per_s * elapsed_s)
    ahead = abs(target - measured_norm) < abs(target - model) or (
        abs(command_norm - measured_norm) < abs(command_norm - model)
    )
    return measured_norm if ahead else model


def _encoder_step(
    state: MonitorState,
    low_since: float | None,
    inputs: MonitorInputs,
    now: float,
    config: MonitorConfig,
) -> tuple[MonitorState, bool]:
    """The encoder monitor: the new state (with the pressure's `low_since`) and whether it
    faults."""
    measured = inputs.steering_measured_norm
    if measured is None or not abs(measured) <= config.encoder_valid_limit_norm:
        return MonitorState(low_since, updated_at=now), measured is not None
    # The servo gets what pulse_for_steering makes of the command: NaN centres, the rest clamps.
    command = clamp_norm(inputs.steering_command_norm)
    model = _servo_model(state, measured, command, now, config)
    tolerance = config.steering_tolerance_norm
    late = abs(command - measured) > tolerance and abs(command - model) <= tolerance
    late_since = _since(state.steering_late_since, late, now)
    new_state = MonitorState(low_since, late_since, model, command, now)
    return new_state, _lasted(late_since, now, config.steering_margin_s)


def monitor_step(
    state: MonitorState, inputs: MonitorInputs, now: float, config: MonitorConfig
) -> tuple[MonitorState, ErrorFlag]:
    """One monitoring step at `now`: the new state and the raised flags. Pure: reads no clock."""
    low_since = _since(state.pressure_low_since, _pressure_low(inputs, config), now)
    state, encoder_fault = _encoder_step(state, low_since, inputs, now, config)
    flags = NO_FLAGS
    if _lasted(low_since, now, config.hydro_response_s):
        flags |= ErrorFlag.HYDRO_PRESSURE_FAULT
    if encoder_fault:
        flags |= ErrorFlag.STEERING_ENCODER_FAULT
    return state, flags


def stopping_flags(flags: int, config: MonitorConfig = DEFAULT_MONITOR_CONFIG) -> int:
    """Those of `flags` the configuration says demand STOP (plain ints: see controller_step)."""
    return int(flags) & int(config.stop_flags)


def stop_required(flags: int, config: MonitorConfig = DEFAULT_MONITOR_CONFIG) -> bool:
    """Whether any of `flags` is one the configuration says demands STOP."""
    return bool(stopping_flags(flags, config))
