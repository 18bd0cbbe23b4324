"""Actuator sections: the drive DAC and motor lines, brakes, lights and the periodic tasks' rates
and lines, into their dataclasses."""

from __future__ import annotations

from dataclasses import fields, replace

from bywire.config.dac_backends import DAC_BACKEND_NAMES
from bywire.config.limits import (
    BLINK_HZ,
    BRAKE_PWM_HZ,
    GPIO_OFFSETS,
    I2C_BUSES,
    MOTOR_VOLTS,
    TASK_RATE_HZ,
    THRESHOLD_NORM,
    VREF_VOLTS,
)
from bywire.config.reader import MISSING, Table, toml_type
from bywire.config.sections import pwm
from bywire.config.tree import (
    ESTOP_DEFAULT_LINE,
    ESTOP_NONE,
    TASK_LINE_SUFFIX,
    DacOutput,
    DriveSection,
    EbrakeSection,
    EstopSection,
    GpioLine,
    HydrobrakeSection,
    LightsSection,
    TasksSection,
)
from bywire.control.drive import DriveConfig
from bywire.protocol import dac6574

LINE_FORMS = f"a line name (string) or an offset (integer {GPIO_OFFSETS[0]}..{GPIO_OFFSETS[-1]})"


def hex_address(address: int) -> str:
    return f"0x{address:02X}"


def drive_section(table: Table, chip: str) -> DriveSection:
    default, limits = DriveSection(), DriveConfig()
    section = DriveSection(
        limits=DriveConfig(
            max_throttle_volts=table.number(
                "max_throttle_volts", limits.max_throttle_volts, MOTOR_VOLTS
            ),
            max_regen_volts=table.number("max_regen_volts", limits.max_regen_volts, MOTOR_VOLTS),
        ),
        dac=dac(table.table("dac")),
        motors_enable=gpio_line(table, "motors_enable", GpioLine(chip, default.motors_enable.line)),
        motors_forward=gpio_line(
            table, "motors_forward", GpioLine(chip, default.motors_forward.line)
        ),
        motors_reverse=gpio_line(
            table, "motors_reverse", GpioLine(chip, default.motors_reverse.line)
        ),
    )
    table.close()
    return section


def dac(table: Table) -> DacOutput:
    default = DacOutput()
    output = DacOutput(
        i2c_bus=table.integer("i2c_bus", default.i2c_bus, I2C_BUSES),
        address=table.integer("address", default.address, dac6574.ADDRESSES, hex_address),
        vref_volts=table.number("vref_volts", default.vref_volts, VREF_VOLTS),
        throttle_channel=table.integer(
            "throttle_channel", default.throttle_channel, dac6574.CHANNELS
        ),
        regen_channel=table.integer("regen_channel", default.regen_channel, dac6574.CHANNELS),
        backend=table.text("backend", default.backend, DAC_BACKEND_NAMES),
    )
    table.close()
    return output


def hydrobrake_section(table: Table) -> HydrobrakeSection:
    default = HydrobrakeSection()
    section = HydrobrakeSection(
        threshold_norm=table.number("threshold_norm", default.threshold_norm, THRESHOLD_NORM),
        pwm=pwm(table.table("pwm"), default.pwm, BRAKE_PWM_HZ),
    )
    table.close()
    return section


def ebrake_section(table: Table, chip: str) -> EbrakeSection:
    default = EbrakeSection()
    line = gpio_line(table, "ebrake_release", GpioLine(chip, default.ebrake_release.line))
    table.close()
    return EbrakeSection(ebrake_release=line)


def estop_section(table: Table, chip: str) -> EstopSection:
    """`line`: the E-stop's input line (any form `gpio_line` takes) or "none"; a file without
    the key takes the default line, marked as not stated (`EstopSection`)."""
    value = table.get("line")
    if value is MISSING:
        section = EstopSection(GpioLine(chip, ESTOP_DEFAULT_LINE), stated=False)
    elif value == ESTOP_NONE:
        section = EstopSection(line=None)
    elif isinstance(value, bool) or not isinstance(value, str | int | dict):
        allowed = f'{LINE_FORMS}, a table {{ chip = ..., line = ... }}, or "{ESTOP_NONE}"'
        table.refuse("line", value, f"expected {allowed}, got {toml_type(value)}")
        section = EstopSection(line=None)
    else:
        section = EstopSection(line=gpio_line(table, "line", GpioLine(chip, ESTOP_DEFAULT_LINE)))
    table.close()
    return section


def lights_section(table: Table, chip: str) -> LightsSection:
    """Every `GpioLine` field of `LightsSection` is a key here: a new lamp needs no reader."""
    default = LightsSection()
    blink_rate_hz = table.number("blink_rate_hz", default.blink_rate_hz, BLINK_HZ)
    lines = {
        field.name: gpio_line(table, field.name, GpioLine(chip, line.line))
        for field in fields(LightsSection)
        if isinstance(line := getattr(default, field.name), GpioLine)
    }
    section = replace(default, blink_rate_hz=blink_rate_hz, **lines)
    table.close()
    return section


def tasks_section(table: Table, chip: str) -> TasksSection:
    """`<name>_rate_hz` for each task of the schedule table and `<line>_line` for each line of
    its line tasks; any other key is refused."""
    default = TasksSection()
    rates = tuple(
        (name, table.number(f"{name}_rate_hz", default_hz, TASK_RATE_HZ))
        for name, default_hz in default.rates_hz
    )
    lines = tuple(
        (name, gpio_line(table, f"{name}{TASK_LINE_SUFFIX}", GpioLine(chip, line.line)))
        for name, line in default.lines
    )
    table.close()
    return TasksSection(rates, lines)


def gpio_line(table: Table, name: str, default: GpioLine) -> GpioLine:
    """A line given as a name or offset on the default chip, or as { chip = ..., line = ... }."""
    value = table.get(name)
    if value is MISSING:
        return default
    if not isinstance(value, dict):
        return GpioLine(default.chip, _line(table, name, value, default.line))
    inner = table.table(name)
    chip = inner.text("chip", default.chip)
    line = inner.get("line")
    if line is MISSING:
        key = inner.key("line")
        inner.problems.add(key, f"{key} is missing: give {LINE_FORMS}")
        line = default.line
    inner.close()
    return GpioLine(chip, _line(inner, "line", line, default.line))


def _line(table: Table, name: str, value: object, default: str | int) -> str | int:
    if isinstance(value, str) and value.strip():
        return value
    if isinstance(value, int) and not isinstance(value, bool):
        if value in GPIO_OFFSETS:
            return value
        table.refuse(name, value, f"out of range; allowed {LINE_FORMS}")
        return default
    table_form = "or a table { chip = ..., line = ... }"
    table.refuse(name, value, f"expected {LINE_FORMS}, {table_form}, got {toml_type(value)}")
    return default
