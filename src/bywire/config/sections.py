"""Bus, input and timing sections: one TOML table each into its dataclass, range-checked."""

from __future__ import annotations

import re
from dataclasses import replace

from bywire.config.limits import (
    BITRATES_BPS,
    BOOST_GAIN,
    CLOCKS_HZ,
    CONTROLLED_STOP_S,
    CPU_NUMBERS,
    DEADBAND_NORM,
    DEBOUNCE_FRAMES,
    DEBOUNCE_WHY,
    DUTY,
    DWELL_S,
    FIFO_PRIORITY,
    HANDOVER_RATE,
    IBUS_BAUD,
    INPUT_TIMEOUT_S,
    PASS_BUDGET_S,
    POSITIVE_NORM_PER_S,
    PRESSURE_BAR,
    PULSE_S,
    PWM_CHANNELS,
    RC_CHANNELS,
    RC_FRAME_PERIOD_S,
    RC_RAW,
    RESPONSE_S,
    SAMPLE_POINT,
    SEEDS,
    SERVO_PWM_HZ,
    SLEW_PER_S,
    SPEED_CHANGE_MPS2,
    SPEED_STEP_MPS,
    STANDSTILL_MPS,
    STOP_DECEL_MPS2,
    STOP_RESPONSE_S,
    SWITCH_BAND_RAW,
    SWITCH_HYSTERESIS_RAW,
    TELEMETRY_RATE_HZ,
    TOLERANCE_NORM,
    TOP_SPEED_MPS,
    WATCHDOG_S,
    WRITE_BUDGET_S,
)
from bywire.config.reader import MISSING, Interval, Table, toml_type
from bywire.config.tree import (
    ALL_CPUS,
    CAN_COMMAND_NAMES,
    GC_MODES,
    SCHEDULERS,
    CanSection,
    PwmOutput,
    RcSection,
    RealtimeSection,
    SimSection,
    SteeringSection,
    StopSection,
    TelemetrySection,
    TimeoutsSection,
    parse_cpu_list,
)
from bywire.control.interlocks import InterlockConfig
from bywire.control.rc_mapping import (
    AxisCalibration,
    FailsafeSignature,
    RcMapping,
    SwitchCalibration,
)
from bywire.control.sensor_checks import MonitorConfig
from bywire.control.steering import SteeringConfig
from bywire.control.supervisor import SupervisorConfig
from bywire.errors import ConfigError
from bywire.loopback import parse_listen_address

ORIGIN = re.compile(r"https?://[A-Za-z0-9.-]+(:[0-9]{1,5})?|file://")


def can_section(table: Table) -> CanSection:
    default = CanSection()
    clock = table.get("clock_hz")
    section = CanSection(
        interface=table.text("interface", default.interface, can_interfaces()),
        channel=table.text("channel", default.channel),
        bitrate_bps=table.integer("bitrate_bps", default.bitrate_bps, BITRATES_BPS),
        sample_point=table.number("sample_point", default.sample_point, SAMPLE_POINT),
        clock_hz=None if clock is MISSING else table.integer("clock_hz", 0, CLOCKS_HZ) or None,
    )
    table.close()
    return section


def can_interfaces() -> tuple[str, ...]:
    """python-can's interface names, plugins included (imported here: python-can is slow)."""
    import can  # noqa: PLC0415

    return tuple(sorted(can.VALID_INTERFACES))


def rc_section(table: Table) -> RcSection:
    default, mapping = RcSection(), RcMapping()
    section = RcSection(
        port=table.text("port", default.port),
        baud=table.integer("baud", default.baud, IBUS_BAUD),
        mapping=RcMapping(
            steering=axis(table.table("steering"), mapping.steering),
            throttle_brake=axis(table.table("throttle_brake"), mapping.throttle_brake),
            mode_switch=switch(table.table("mode_switch"), mapping.mode_switch),
            gear_switch=switch(table.table("gear_switch"), mapping.gear_switch),
            low_beam_switch=switch(table.table("low_beam_switch"), mapping.low_beam_switch),
            hazard_switch=switch(table.table("hazard_switch"), mapping.hazard_switch),
            failsafe=failsafe(table.table("failsafe"), mapping.failsafe),
        ),
    )
    table.close()
    return section


def axis(table: Table, default: AxisCalibration) -> AxisCalibration:
    calibration = AxisCalibration(
        channel=table.integer("channel", default.channel, RC_CHANNELS),
        min_raw=table.integer("min_raw", default.min_raw, RC_RAW),
        center_raw=table.integer("center_raw", default.center_raw, RC_RAW),
        max_raw=table.integer("max_raw", default.max_raw, RC_RAW),
        deadband_norm=table.number("deadband_norm", default.deadband_norm, DEADBAND_NORM),
        reverse=table.flag("reverse", default.reverse),
    )
    table.close()
    return calibration


def failsafe(table: Table, default: FailsafeSignature) -> FailsafeSignature:
    signature = FailsafeSignature(
        channel=table.integer("channel", default.channel, RC_CHANNELS),
        below_raw=table.integer("below_raw", default.below_raw, RC_RAW),
    )
    table.close()
    return signature


def switch(table: Table, default: SwitchCalibration) -> SwitchCalibration:
    """One switch: its channel, each position's nominal pulse (as many as the switch has, low
    to high), the band around each and the hysteresis (R-SWITCH); the bands and their
    hysteresis may not touch: a value between two of them is no position."""
    count = len(default.positions_raw)
    positions = table.integer_list("positions_raw", default.positions_raw, RC_RAW, count)
    calibration = SwitchCalibration(
        channel=table.integer("channel", default.channel, RC_CHANNELS),
        reverse=table.flag("reverse", default.reverse),
        positions_raw=positions,
        band_raw=table.integer("band_raw", default.band_raw, SWITCH_BAND_RAW),
        hysteresis_raw=table.integer(
            "hysteresis_raw", default.hysteresis_raw, SWITCH_HYSTERESIS_RAW
        ),
    )
    table.close()
    return calibration


def steering_section(table: Table) -> SteeringSection:
    default = SteeringConfig()
    servo = SteeringConfig(
        min_pulse_s=table.number("min_pulse_s", default.min_pulse_s, PULSE_S),
        center_pulse_s=table.number("center_pulse_s", default.center_pulse_s, PULSE_S),
        max_pulse_s=table.number("max_pulse_s", default.max_pulse_s, PULSE_S),
        reverse=table.flag("reverse", default.reverse),
        rate_limit_norm_per_s=table.number(
            "rate_limit_norm_per_s", default.rate_limit_norm_per_s, POSITIVE_NORM_PER_S
        ),
        boost_gain=table.number("boost_gain", default.boost_gain, BOOST_GAIN),
        servo_speed_norm_per_s=table.number(
            "servo_speed_norm_per_s", default.servo_speed_norm_per_s, POSITIVE_NORM_PER_S
        ),
        handover_rate_norm_per_s=table.number(
            "handover_rate_norm_per_s", default.handover_rate_norm_per_s, HANDOVER_RATE
        ),
    )
    section = SteeringSection(servo, pwm(table.table("pwm"), SteeringSection().pwm, SERVO_PWM_HZ))
    table.close()
    return section


def pwm(table: Table, default: PwmOutput, frequencies: Interval) -> PwmOutput:
    output = PwmOutput(
        chip=table.text("chip", default.chip),
        channel=table.integer("channel", default.channel, PWM_CHANNELS),
        frequency_hz=table.number("frequency_hz", default.frequency_hz, frequencies),
    )
    table.close()
    return output


def timeouts_section(table: Table) -> TimeoutsSection:
    """The input timeouts; `[timeouts.can_message_timeout_s]` names CAN command messages whose
    own limit differs from `can_command_timeout_s` (any other name is refused)."""
    default = TimeoutsSection()
    can_default_s = table.number(
        "can_command_timeout_s", default.can_command_timeout_s, INPUT_TIMEOUT_S
    )
    messages = table.table("can_message_timeout_s")
    per_message = tuple(
        (name, messages.number(name, can_default_s, INPUT_TIMEOUT_S)) for name in CAN_COMMAND_NAMES
    )
    messages.close()
    section = TimeoutsSection(
        rc_timeout_s=table.number("rc_timeout_s", default.rc_timeout_s, INPUT_TIMEOUT_S),
        can_command_timeout_s=can_default_s,
        watchdog_s=table.number("watchdog_s", default.watchdog_s, WATCHDOG_S),
        stop_response_s=table.number("stop_response_s", default.stop_response_s, STOP_RESPONSE_S),
        pass_budget_s=table.number("pass_budget_s", default.pass_budget_s, PASS_BUDGET_S),
        write_budget_s=table.number("write_budget_s", default.write_budget_s, WRITE_BUDGET_S),
        dac_transfer_budget_s=table.number(
            "dac_transfer_budget_s", default.dac_transfer_budget_s, WRITE_BUDGET_S
        ),
        can_message_timeout_s=per_message,
    )
    table.close()
    return section


def stop_section(table: Table) -> StopSection:
    default = StopSection()
    section = StopSection(
        controlled_max_s=table.number(
            "controlled_max_s", default.controlled_max_s, CONTROLLED_STOP_S
        ),
        controlled_min_decel_mps2=table.number(
            "controlled_min_decel_mps2", default.controlled_min_decel_mps2, STOP_DECEL_MPS2
        ),
    )
    table.close()
    return section


def sim_section(table: Table) -> SimSection:
    default = SimSection()
    section = SimSection(
        seed=table.integer("seed", default.seed, SEEDS),
        rc_frame_period_s=table.number(
            "rc_frame_period_s", default.rc_frame_period_s, RC_FRAME_PERIOD_S
        ),
        top_speed_mps=table.number("top_speed_mps", default.top_speed_mps, TOP_SPEED_MPS),
    )
    table.close()
    return section


def interlocks_section(table: Table) -> InterlockConfig:
    default = InterlockConfig()
    section = InterlockConfig(
        standstill_speed_mps=table.number(
            "standstill_speed_mps", default.standstill_speed_mps, STANDSTILL_MPS
        ),
        direction_dwell_s=table.number("direction_dwell_s", default.direction_dwell_s, DWELL_S),
        unknown_speed_dwell_s=table.number(
            "unknown_speed_dwell_s", default.unknown_speed_dwell_s, DWELL_S
        ),
        unknown_speed_brake_norm=table.number(
            "unknown_speed_brake_norm", default.unknown_speed_brake_norm, DUTY
        ),
        throttle_slew_up_per_s=table.number(
            "throttle_slew_up_per_s", default.throttle_slew_up_per_s, SLEW_PER_S
        ),
        speed_max_change_mps2=table.number(
            "speed_max_change_mps2", default.speed_max_change_mps2, SPEED_CHANGE_MPS2
        ),
        speed_step_tolerance_mps=table.number(
            "speed_step_tolerance_mps", default.speed_step_tolerance_mps, SPEED_STEP_MPS
        ),
        speed_stuck_throttle_norm=table.number(
            "speed_stuck_throttle_norm", default.speed_stuck_throttle_norm, DUTY
        ),
        speed_stuck_s=table.number("speed_stuck_s", default.speed_stuck_s, DWELL_S),
    )
    table.close()
    return section


def monitors_section(table: Table) -> MonitorConfig:
    default = MonitorConfig()

    def number(name: str, allowed: Interval) -> float:
        default_value: float = getattr(default, name)
        return table.number(name, default_value, allowed)

    section = MonitorConfig(
        hydro_min_duty=number("hydro_min_duty", DUTY),
        hydro_response_s=number("hydro_response_s", RESPONSE_S),
        hydro_bar_at_full_duty=number("hydro_bar_at_full_duty", PRESSURE_BAR),
        steering_tolerance_norm=number("steering_tolerance_norm", TOLERANCE_NORM),
        servo_speed_norm_per_s=number("servo_speed_norm_per_s", POSITIVE_NORM_PER_S),
        steering_margin_s=number("steering_margin_s", RESPONSE_S),
    )
    table.close()
    return section


def supervisor_section(table: Table) -> SupervisorConfig:
    default = SupervisorConfig()
    section = SupervisorConfig(
        debounce_frames=table.integer(
            "debounce_frames", default.debounce_frames, DEBOUNCE_FRAMES, why=DEBOUNCE_WHY
        )
    )
    table.close()
    return section


def realtime_section(table: Table) -> RealtimeSection:
    default = RealtimeSection()
    scheduler = table.text("scheduler", default.scheduler, SCHEDULERS)
    gc_mode = table.text("gc_mode", default.gc_mode, GC_MODES)
    section = RealtimeSection(
        scheduler="fifo" if scheduler == "fifo" else "other",
        priority=table.integer("priority", default.priority, FIFO_PRIORITY),
        lock_memory=table.flag("lock_memory", default.lock_memory),
        cpus=cpu_list(table, "cpus", default.cpus),
        gc_freeze=table.flag("gc_freeze", default.gc_freeze),
        gc_mode="idle" if gc_mode == "idle" else "automatic",
    )
    table.close()
    return section


def cpu_list(table: Table, name: str, default: str) -> str:
    """A CPU list ("1", "2-3", "0,2") of CPUs in CPU_NUMBERS, or "all"."""
    allowed = (
        f'"{ALL_CPUS}" or a CPU list such as "1" or "0,2-3"'
        f" (CPUs {CPU_NUMBERS.start}..{CPU_NUMBERS[-1]})"
    )
    value = table.get(name)
    if value is MISSING:
        return default
    if not isinstance(value, str):
        table.refuse(name, value, f"expected {allowed}, got {toml_type(value)}")
        return default
    if value == ALL_CPUS:
        return value
    try:
        cpus = parse_cpu_list(value)
    except ValueError:
        table.refuse(name, value, f"not a CPU list; expected {allowed}")
        return default
    if not cpus <= set(CPU_NUMBERS):
        table.refuse(name, value, f"out of range; allowed {allowed}")
        return default
    return value


def telemetry_section(table: Table) -> TelemetrySection:
    default = TelemetrySection()
    allow_remote = table.flag("allow_remote", default.allow_remote)
    section = TelemetrySection(
        rate_hz=table.number("rate_hz", default.rate_hz, TELEMETRY_RATE_HZ),
        mcap=_optional_text(table, "mcap"),
        foxglove=_optional_text(table, "foxglove"),
        allow_remote=allow_remote,
        allowed_origins=_origins(table, "allowed_origins"),
    )
    if section.mcap is not None and not section.mcap.lower().endswith(".mcap"):
        table.refuse("mcap", section.mcap, "an MCAP file's name ends in .mcap")
        section = replace(section, mcap=None)
    if section.foxglove is not None:
        try:
            parse_listen_address(section.foxglove, allow_remote=allow_remote)
        except ConfigError as error:
            reason = str(error)
            if "loopback only" in reason:
                reason = (
                    "loopback only (127.0.0.1, ::1 or localhost) unless"
                    f" {table.key('allow_remote')} = true: the feed has no authentication"
                )
            table.refuse("foxglove", section.foxglove, reason)
            section = replace(section, foxglove=None)
    table.close()
    return section


def _origins(table: Table, name: str) -> tuple[str, ...]:
    """Web origins ("https://app.foxglove.dev"): scheme, host and an optional port."""
    value = table.get(name)
    if value is MISSING:
        return ()
    allowed = 'an array of origins such as ["https://app.foxglove.dev"]'
    if not isinstance(value, list):
        table.refuse(name, value, f"expected {allowed}, got {toml_type(value)}")
        return ()
    if not all(isinstance(item, str) and ORIGIN.fullmatch(item) for item in value):
        table.refuse(name, value, f"expected {allowed} (scheme://host[:port], no path)")
        return ()
    return tuple(value)


def _optional_text(table: Table, name: str) -> str | None:
    """A non-empty string, or None when the key is absent (or refused)."""
    value = table.get(name)
    if value is MISSING:
        return None
    return table.text(name, "") or None
