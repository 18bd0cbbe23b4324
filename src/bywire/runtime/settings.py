"""The runtime's configuration: the decision's, the actuators', the schedule and the watchdog."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from bywire.config import RobotConfig, TimeoutsSection
from bywire.config.deadlines import standstill_hold_s
from bywire.config.speed_limit import governor_config
from bywire.control.controller import ControlConfig
from bywire.control.stop import STANDSTILL_LIMIT_MPS, StopConfig
from bywire.runtime.actuators import ActuatorConfig
from bywire.runtime.rx_checks import RxCheck, rx_checks
from bywire.runtime.timing import Budgets
from bywire.task_table import SCHEDULE, TaskSpec


def _stop_config(robot: RobotConfig) -> StopConfig:
    stop = StopConfig(
        controlled_max_s=robot.stop.controlled_max_s,
        controlled_min_decel_mps2=robot.stop.controlled_min_decel_mps2,
        standstill_mps=min(robot.interlocks.standstill_speed_mps, STANDSTILL_LIMIT_MPS),
    )
    hold_s = min(standstill_hold_s(robot), stop.controlled_max_s)
    return replace(stop, standstill_hold_s=hold_s)


@dataclass(frozen=True, slots=True)
class RuntimeConfig:
    """Everything the runtime needs: the decision's configuration, the actuators', the schedule,
    the watchdog, the receive check of each CAN command message, and whether start-up's objects
    are frozen out of the collector's sight (`[realtime] gc_freeze`)."""

    control: ControlConfig = field(default_factory=ControlConfig)
    actuators: ActuatorConfig = field(default_factory=ActuatorConfig)
    schedule: tuple[TaskSpec, ...] = SCHEDULE
    watchdog_s: float | None = None  # None: no watchdog thread (virtual time has no stalls)
    rx_checks: tuple[RxCheck, ...] = field(default_factory=lambda: rx_checks(TimeoutsSection()))
    gc_freeze: bool = True

    @classmethod
    def from_robot(cls, robot: RobotConfig) -> RuntimeConfig:
        """The runtime's view of a robot's validated configuration."""
        servo = robot.steering.servo
        checks = rx_checks(robot.timeouts)
        control = ControlConfig(
            steering=servo,
            drive=robot.drive.limits,
            rc_mapping=robot.rc.mapping,
            hydrobrake_threshold_norm=robot.hydrobrake.threshold_norm,
            rc_timeout_s=robot.timeouts.rc_timeout_s,
            command_timeouts_s=tuple((check.kind, check.timeout_s) for check in checks),
            blink_rate_hz=robot.lights.blink_rate_hz,
            interlocks=robot.interlocks,
            monitors=robot.monitors,
            supervisor=robot.supervisor,
            stop=_stop_config(robot),
            governor=governor_config(robot.limits, robot.vehicle),
        )
        timeouts = robot.timeouts
        schedule = tuple(replace(spec, rate_hz=robot.tasks.rate_hz(spec.name)) for spec in SCHEDULE)
        actuators = ActuatorConfig(
            line_tasks=tuple(spec for spec in schedule if spec.lines),
            dac=robot.drive.dac,
            safe_steering_pulse_s=servo.center_pulse_s,
            budgets=Budgets(
                pass_budget_s=timeouts.pass_budget_s,
                write_budget_s=timeouts.write_budget_s,
                dac_transfer_budget_s=timeouts.dac_transfer_budget_s,
            ),
        )
        return cls(
            control,
            actuators,
            schedule,
            robot.timeouts.watchdog_s,
            checks,
            gc_freeze=robot.realtime.gc_freeze,
        )
