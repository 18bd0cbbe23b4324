"""Checks across keys: min < centre < max, one function per channel or line, exact bit timing."""

from __future__ import annotations

from collections.abc import Sequence
from itertools import pairwise

from bywire.config.deadlines import breaches
from bywire.config.reader import Problems, number_text, show
from bywire.config.tree import OUTPUT_LINE_KEYS, CanSection, RobotConfig, output_lines
from bywire.errors import ConfigError
from bywire.protocol import bittiming
from bywire.task_table import SUPERVISED_TASKS

CONTROL_TASKS = SUPERVISED_TASKS  # the actuator tasks the watchdog covers (the rows say which)
RC_AXES = ("steering", "throttle_brake")
RC_SWITCHES = ("mode_switch", "gear_switch", "low_beam_switch", "hazard_switch")
RC_FUNCTIONS = (*RC_AXES, *RC_SWITCHES)
WATCHDOG_PERIODS = 2  # a watchdog shorter than two control periods would bite a healthy loop
CAN_TIMEOUT_PERIODS = 2  # a CAN command's timeout spans two DBC periods: a lost frame is no STOP


def check_consistency(config: RobotConfig, problems: Problems) -> None:
    """Record every problem that no single key shows; keys that already failed are skipped."""
    checks = (
        _calibrations,
        _rc_channels,
        _switch_bands,
        _dac,
        _outputs,
        _bit_timing,
        _watchdog,
        _can_timeouts,
        _deadlines,
        _report_rate,  # after the deadlines: a breach there names every task's rate
    )
    for check in checks:
        check(config, problems)


def _calibrations(config: RobotConfig, problems: Problems) -> None:
    servo = config.steering.servo
    pulses = (servo.min_pulse_s, servo.center_pulse_s, servo.max_pulse_s)
    _increasing(problems, "steering", ("min_pulse_s", "center_pulse_s", "max_pulse_s"), pulses)
    for axis_name in RC_AXES:
        axis = getattr(config.rc.mapping, axis_name)
        raws = (axis.min_raw, axis.center_raw, axis.max_raw)
        _increasing(problems, f"rc.{axis_name}", ("min_raw", "center_raw", "max_raw"), raws)


def _switch_bands(config: RobotConfig, problems: Problems) -> None:
    """Two positions' bands, widened by the hysteresis, may not touch: a value between them must
    read as no position (R-SWITCH), never as the position held before."""
    for name in RC_SWITCHES:
        switch = getattr(config.rc.mapping, name)
        key = f"rc.{name}"
        if problems.affects(key):
            continue
        reach = switch.band_raw + switch.hysteresis_raw
        gaps = [b - a for a, b in pairwise(switch.positions_raw)]
        if gaps and min(gaps) <= 2 * reach:
            largest = max(min(gaps) // 2 - switch.hysteresis_raw - 1, 0)
            problems.add(
                f"{key}.band_raw",
                f"{key}: positions {list(switch.positions_raw)} µs are {min(gaps)} µs apart,"
                f" too close for bands of ±{switch.band_raw} µs with ±{switch.hysteresis_raw}"
                f" µs of hysteresis (they would touch); set band_raw to {largest} or less",
            )


def _rc_channels(config: RobotConfig, problems: Problems) -> None:
    mapping = config.rc.mapping
    channels = [(f"rc.{name}.channel", getattr(mapping, name).channel) for name in RC_FUNCTIONS]
    _distinct(problems, channels, "RC channel")


def _dac(config: RobotConfig, problems: Problems) -> None:
    dac = config.drive.dac
    channels = [("drive.dac.throttle_channel", dac.throttle_channel)]
    _distinct(problems, [*channels, ("drive.dac.regen_channel", dac.regen_channel)], "channel")
    for name in ("max_throttle_volts", "max_regen_volts"):
        _within_vref(problems, name, getattr(config.drive.limits, name), dac.vref_volts)


def _outputs(config: RobotConfig, problems: Problems) -> None:
    pwms = [("steering.pwm", config.steering.pwm), ("hydrobrake.pwm", config.hydrobrake.pwm)]
    _distinct(problems, [(key, (pwm.chip, pwm.channel)) for key, pwm in pwms], "PWM chip, channel")
    lines = output_lines(config)
    keyed = [(key, (lines[name].chip, lines[name].line)) for name, key in OUTPUT_LINE_KEYS.items()]
    estop = config.estop.line
    if estop is not None:  # an input on an output's line would read back what it drives
        keyed.append(("estop.line", (estop.chip, estop.line)))
    _distinct(problems, keyed, "GPIO chip, line")


def _increasing(
    problems: Problems, section: str, names: Sequence[str], values: Sequence[float]
) -> None:
    keys = [f"{section}.{name}" for name in names]
    if problems.affects(*keys) or all(a < b for a, b in pairwise(values)):
        return
    shown = ", ".join(f"{key} = {show(value)}" for key, value in zip(keys, values, strict=True))
    problems.add(keys[1], f"{shown}: must increase (min < center < max)")


def _distinct(problems: Problems, items: Sequence[tuple[str, object]], what: str) -> None:
    seen: dict[object, str] = {}
    for key, value in items:
        if problems.affects(key):
            continue
        if value in seen:
            shown = ", ".join(map(show, value)) if isinstance(value, tuple) else show(value)
            problems.add(key, f"{seen[value]} and {key} both use {what} {shown}: give each its own")
        seen.setdefault(value, key)


def _within_vref(problems: Problems, name: str, volts: float, vref_volts: float) -> None:
    key = f"drive.{name}"
    if volts > vref_volts and not problems.affects(key, "drive.dac.vref_volts"):
        limit = f"allowed 0..{number_text(vref_volts)} V (drive.dac.vref_volts)"
        problems.add(key, f"{key} = {show(volts)}: the DAC cannot exceed its reference; {limit}")


def _bit_timing(config: RobotConfig, problems: Problems) -> None:
    can, keys = config.can, ("can.bitrate_bps", "can.clock_hz", "can.sample_point")
    if can.clock_hz is None or problems.affects(*keys):
        return
    where = f"can.bitrate_bps = {can.bitrate_bps} with can.clock_hz = {can.clock_hz}"
    try:
        if bittiming.solutions(can.clock_hz, can.bitrate_bps, can.sample_point):
            return
    except ConfigError as error:
        problems.add(keys[0], f"{where}: {error}")
        return
    exact = [rate for rate in bittiming.STANDARD_BITRATES_BPS if _exact(can, rate)]
    allowed = ", ".join(map(str, exact)) or "none of the standard bitrates"
    problems.add(
        keys[0],
        f"{where}: no exact bxCAN bit timing at sample point {can.sample_point};"
        f" allowed on this clock: {allowed}",
    )


def _exact(can: CanSection, bitrate_bps: int) -> bool:
    try:
        return bool(bittiming.solutions(can.clock_hz or 0, bitrate_bps, can.sample_point))
    except ConfigError:
        return False


def _watchdog(config: RobotConfig, problems: Problems) -> None:
    keys = ["timeouts.watchdog_s", *(f"tasks.{name}_rate_hz" for name in CONTROL_TASKS)]
    if problems.affects(*keys):
        return
    slowest = min(CONTROL_TASKS, key=config.tasks.rate_hz)
    slowest_hz = config.tasks.rate_hz(slowest)
    minimum_s = WATCHDOG_PERIODS / slowest_hz
    if config.timeouts.watchdog_s < minimum_s:
        problems.add(
            keys[0],
            f"timeouts.watchdog_s = {show(config.timeouts.watchdog_s)}: shorter than"
            f" {WATCHDOG_PERIODS} periods of tasks.{slowest}_rate_hz = {show(slowest_hz)};"
            f" allowed >= {number_text(minimum_s)} s",
        )


def _report_rate(config: RobotConfig, problems: Problems) -> None:
    """The reports go out at least as often as their DBC period (GenMsgCycleTime) says: the
    higher-level computer judges their age by it, as the controller judges the commands'."""
    from bywire.protocol import dbc  # noqa: PLC0415 (cantools only when a file is checked)

    key = "tasks.can_tx_rate_hz"
    if problems.affects(key):
        return
    period_s = min(dbc.period_s(frame) for frame in dbc.report_ids())
    rate_hz = config.tasks.rate_hz("can_tx")
    if 1.0 / rate_hz > period_s * (1.0 + 1e-9):
        problems.add(
            key,
            f"{key} = {show(rate_hz)}: the reports would go out less often than their period in"
            f" the DBC ({number_text(period_s)} s, GenMsgCycleTime), so the higher-level computer"
            f" would take them for late; allowed >= {number_text(1.0 / period_s)} Hz",
        )


def _can_timeouts(config: RobotConfig, problems: Problems) -> None:
    """Each CAN command's timeout spans CAN_TIMEOUT_PERIODS of its period in the DBC. A message
    on the section's default is reported under `can_command_timeout_s`, the key to change."""
    from bywire.command_table import COMMAND_TYPES  # noqa: PLC0415 (cantools when checked)
    from bywire.protocol import dbc  # noqa: PLC0415

    timeouts = config.timeouts
    default_key = "timeouts.can_command_timeout_s"
    if problems.affects(default_key, "timeouts.can_message_timeout_s"):
        return
    on_default: list[str] = []
    least_s = 0.0
    for kind in COMMAND_TYPES:
        name = kind.__name__
        timeout_s = timeouts.can_timeout_s(name)
        minimum_s = CAN_TIMEOUT_PERIODS * dbc.period_s(dbc.frame_id(kind))
        if timeout_s >= minimum_s - 1e-9:
            continue
        if timeout_s == timeouts.can_command_timeout_s:
            on_default.append(name)
            least_s = max(least_s, minimum_s)
            continue
        key = f"timeouts.can_message_timeout_s.{name}"
        problems.add(
            key,
            f"{key} = {show(timeout_s)}: shorter than {CAN_TIMEOUT_PERIODS} periods of {name}"
            f" (GenMsgCycleTime in the DBC): one late frame would stop the robot;"
            f" allowed >= {number_text(minimum_s)} s",
        )
    if on_default:
        problems.add(
            default_key,
            f"{default_key} = {show(timeouts.can_command_timeout_s)}: shorter than"
            f" {CAN_TIMEOUT_PERIODS} periods of {', '.join(on_default)} (GenMsgCycleTime in the"
            f" DBC): one late frame would stop the robot; allowed >= {number_text(least_s)} s",
        )


def _deadlines(config: RobotConfig, problems: Problems) -> None:
    """Every physical deadline the file's numbers together must keep (`config.deadlines`)."""
    for breach in breaches(config):
        if not problems.affects(*breach.keys):
            problems.add(breach.keys[0], str(breach))
