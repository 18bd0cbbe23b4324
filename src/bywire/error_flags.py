"""Error flags: one named set of up to 64, reported over CAN and shown on the error LED (R-ERRORS).

Bits 0–10 are Figure 23's flags renamed for a Linux controller; the rest are new. Bit positions are
part of the CAN protocol: the ErrorReport carries each flag as a 1-bit signal named as the flag, at
the bit of its value, with ``DESCRIPTIONS`` as its DBC comment (``bywire.protocol.flag_signals``
renders that block of albert.dbc, and a test holds the file to it). Never renumber, only append.
"""

from __future__ import annotations

import enum


class ErrorFlag(enum.IntFlag):
    """Every condition the controller reports; `RECOVERABLE` ones clear when the cause is gone.

    The others stay up while the STOP they caused is latched (`bywire.control.supervisor`), or,
    for SPEED_SENSOR_FAULT, until the next arming: a latched STOP always names its cause.
    """

    TASK_CRASHED = 1 << 0  # was cubemx_error_handler_activated: in the last report of a crash
    CAN_OPEN_FAILED = 1 << 1  # was can_filter_config_failed / can_start_failed: a re-open
    CAN_BUS_OFF = 1 << 2  # bus-off, interface down or adapter gone: reports back off (§5.2)
    CAN_RX_FAILED = 1 << 3  # was can_rx_get_msg_failed
    CAN_TX_FAILED = 1 << 4  # was can_tx_add_msg_failed
    DAC_VALUE_CLAMPED = 1 << 5  # was driving_motors_send_value_overflow
    DAC_WRITE_FAILED = 1 << 6  # was driving_motors_send_to_dac_failed
    IBUS_PORT_FAILED = 1 << 7  # was ibus_uart_abort_failed / ibus_dma_restart_failed
    RC_TIMEOUT = 1 << 8  # was ibus_signal_timeout
    IBUS_RESYNC = 1 << 9  # was ibus_buffer_misaligned
    IBUS_CHECKSUM = 1 << 10  # was ibus_buffer_crc_mismatch
    CAN_COMMAND_TIMEOUT = 1 << 11
    CAN_COMMAND_REJECTED = 1 << 12  # length, CRC, counter or range
    RC_FAILSAFE = 1 << 13  # the receiver sends its failsafe values
    TASK_OVERRUN = 1 << 14
    WATCHDOG_TRIPPED = 1 << 15
    DAC_FAULT_STOP = 1 << 16  # persistent DAC failure: motors disabled
    HYDRO_PRESSURE_FAULT = 1 << 17
    STEERING_ENCODER_FAULT = 1 << 18
    REMOTE_STOP = 1 << 19  # the higher-level computer asked for STOP
    CAN_UNTRUSTED = 1 << 20  # a command id's counter misses too often: a second sender, a replay
    SPEED_SENSOR_FAULT = 1 << 21  # wheel speeds changed faster than the robot can
    NOT_ARMED = 1 << 22  # power-up STOP: the mode switch has not yet passed through STOP
    CAN_AUTH_FAILED = 1 << 23  # a command failed SecOC verification ([security] on)
    TIMING_FAULT = 1 << 24  # a pass, a port write or a DAC transfer overran its budget
    LIGHTS_UNTRUSTED = 1 << 25  # LightsCommand's id is untrusted: the last trusted lights held
    STOP_ESCALATED = 1 << 26  # a controlled stop did not slow the robot: power removed
    ESTOP_PRESSED = 1 << 27  # the E-stop is pressed or its circuit is open: power off, latched


DESCRIPTIONS: dict[ErrorFlag, str] = {
    ErrorFlag.TASK_CRASHED: "A task raised: the loop ended with outputs safe (the last report).",
    ErrorFlag.CAN_OPEN_FAILED: "Re-opening the lost CAN interface failed; up until it is back.",
    ErrorFlag.CAN_BUS_OFF: "The CAN controller is bus-off, or its interface is down or gone.",
    ErrorFlag.CAN_RX_FAILED: "A CAN receive failed, or frames were dropped from a full queue.",
    ErrorFlag.CAN_TX_FAILED: "Sending a report frame failed.",
    ErrorFlag.DAC_VALUE_CLAMPED: "A motor voltage was clamped to the DAC's range.",
    ErrorFlag.DAC_WRITE_FAILED: "An I2C write to a motor DAC failed (NAK or timeout).",
    ErrorFlag.IBUS_PORT_FAILED: "The RC receiver's serial port is gone or could not be reopened.",
    ErrorFlag.RC_TIMEOUT: "No valid IBUS frame from the RC receiver within the RC timeout.",
    ErrorFlag.IBUS_RESYNC: "The IBUS stream lost its frame alignment and was resynchronised.",
    ErrorFlag.IBUS_CHECKSUM: "An IBUS frame failed its checksum.",
    ErrorFlag.CAN_COMMAND_TIMEOUT: "No accepted CAN command within the command timeout.",
    ErrorFlag.CAN_COMMAND_REJECTED: "A command frame was rejected: length, CRC, counter or range.",
    ErrorFlag.RC_FAILSAFE: "The RC receiver sends its failsafe values: the transmitter is lost.",
    ErrorFlag.TASK_OVERRUN: "A periodic task overran its period.",
    ErrorFlag.WATCHDOG_TRIPPED: "The watchdog tripped: STOP latched until re-armed at STOP.",
    ErrorFlag.DAC_FAULT_STOP: "Persistent DAC failure: motors disabled, STOP latched.",
    ErrorFlag.HYDRO_PRESSURE_FAULT: "The hydraulic brake builds no pressure: STOP latched.",
    ErrorFlag.STEERING_ENCODER_FAULT: "The steering encoder reading is invalid: STOP latched.",
    ErrorFlag.REMOTE_STOP: "The higher-level computer requested STOP (ControlCommand).",
    ErrorFlag.CAN_UNTRUSTED: "A command id's counter misses too often: a second sender, a replay.",
    ErrorFlag.SPEED_SENSOR_FAULT: "Wheel speeds changed faster than the robot can.",
    ErrorFlag.NOT_ARMED: "Power-up STOP: the mode switch has not yet passed through STOP.",
    ErrorFlag.CAN_AUTH_FAILED: "A command failed SecOC verification (authentication on).",
    ErrorFlag.TIMING_FAULT: "A loop pass, port write or DAC transfer overran its budget: STOP.",
    ErrorFlag.LIGHTS_UNTRUSTED: "LightsCommand's id is untrusted: the last trusted lights held.",
    ErrorFlag.STOP_ESCALATED: "A controlled stop did not slow the robot: drive power removed.",
    ErrorFlag.ESTOP_PRESSED: "The E-stop is pressed or its circuit open: power off, STOP latched.",
}
"""What each flag means, one sentence: the comment of its signal in albert.dbc."""


class Subsystem(enum.Enum):
    """The part of the robot a flag speaks of: one ROS 2 diagnostics status each (`bywire.ros2`)."""

    RC_LINK = "RC link"
    CAN_COMMANDS = "CAN commands"
    CAN_CONTROLLER = "CAN controller"
    DRIVE_MOTORS = "drive motors"
    BRAKES = "brakes"
    STEERING = "steering"
    SPEED_SENSOR = "speed sensor"
    CONTROLLER = "controller"
    EMERGENCY_STOP = "emergency stop"


SUBSYSTEMS: dict[ErrorFlag, Subsystem] = {
    ErrorFlag.TASK_CRASHED: Subsystem.CONTROLLER,
    ErrorFlag.CAN_OPEN_FAILED: Subsystem.CAN_CONTROLLER,
    ErrorFlag.CAN_BUS_OFF: Subsystem.CAN_CONTROLLER,
    ErrorFlag.CAN_RX_FAILED: Subsystem.CAN_CONTROLLER,
    ErrorFlag.CAN_TX_FAILED: Subsystem.CAN_CONTROLLER,
    ErrorFlag.DAC_VALUE_CLAMPED: Subsystem.DRIVE_MOTORS,
    ErrorFlag.DAC_WRITE_FAILED: Subsystem.DRIVE_MOTORS,
    ErrorFlag.IBUS_PORT_FAILED: Subsystem.RC_LINK,
    ErrorFlag.RC_TIMEOUT: Subsystem.RC_LINK,
    ErrorFlag.IBUS_RESYNC: Subsystem.RC_LINK,
    ErrorFlag.IBUS_CHECKSUM: Subsystem.RC_LINK,
    ErrorFlag.CAN_COMMAND_TIMEOUT: Subsystem.CAN_COMMANDS,
    ErrorFlag.CAN_COMMAND_REJECTED: Subsystem.CAN_COMMANDS,
    ErrorFlag.RC_FAILSAFE: Subsystem.RC_LINK,
    ErrorFlag.TASK_OVERRUN: Subsystem.CONTROLLER,
    ErrorFlag.WATCHDOG_TRIPPED: Subsystem.CONTROLLER,
    ErrorFlag.DAC_FAULT_STOP: Subsystem.DRIVE_MOTORS,
    ErrorFlag.HYDRO_PRESSURE_FAULT: Subsystem.BRAKES,
    ErrorFlag.STEERING_ENCODER_FAULT: Subsystem.STEERING,
    ErrorFlag.REMOTE_STOP: Subsystem.CAN_COMMANDS,
    ErrorFlag.CAN_UNTRUSTED: Subsystem.CAN_COMMANDS,
    ErrorFlag.SPEED_SENSOR_FAULT: Subsystem.SPEED_SENSOR,
    ErrorFlag.NOT_ARMED: Subsystem.CONTROLLER,
    ErrorFlag.CAN_AUTH_FAILED: Subsystem.CAN_COMMANDS,
    ErrorFlag.TIMING_FAULT: Subsystem.CONTROLLER,
    ErrorFlag.LIGHTS_UNTRUSTED: Subsystem.CAN_COMMANDS,
    ErrorFlag.STOP_ESCALATED: Subsystem.BRAKES,
    ErrorFlag.ESTOP_PRESSED: Subsystem.EMERGENCY_STOP,
}
"""The subsystem of each flag."""


RECOVERABLE = (
    ErrorFlag.CAN_BUS_OFF
    | ErrorFlag.CAN_TX_FAILED
    | ErrorFlag.DAC_VALUE_CLAMPED
    | ErrorFlag.DAC_WRITE_FAILED
    | ErrorFlag.RC_TIMEOUT
    | ErrorFlag.IBUS_RESYNC
    | ErrorFlag.IBUS_CHECKSUM
    | ErrorFlag.CAN_COMMAND_TIMEOUT
    | ErrorFlag.CAN_COMMAND_REJECTED
    | ErrorFlag.CAN_AUTH_FAILED
    | ErrorFlag.RC_FAILSAFE
    | ErrorFlag.TASK_OVERRUN
    | ErrorFlag.LIGHTS_UNTRUSTED
)


def flag_names(flags: int) -> list[str]:
    """The names of the set bits, lowest first; unknown bits appear as `BIT<n>`."""
    known = {flag.value: str(flag.name) for flag in ErrorFlag}
    return [known.get(1 << bit, f"BIT{bit}") for bit in range(64) if flags >> bit & 1]
