"""Error flags: one named 64-bit set, reported over CAN and shown on the error LED (R-ERRORS).

Bits 0–10 are Figure 23's flags renamed for a Linux controller; the rest are new. Bit positions are
part of the CAN protocol (the ErrorReport's 64-bit signal): never renumber, only append.
"""

from __future__ import annotations

import enum


class ErrorFlag(enum.IntFlag):
    """Every condition the controller reports; `RECOVERABLE` ones clear when the cause is gone.

    The others stay up while the STOP they caused is latched (`bywire.control.supervisor`), or,
    for SPEED_SENSOR_FAULT, until the next arming: a latched STOP always names its cause.
    """

    TASK_CRASHED = 1 << 0  # was cubemx_error_handler_activated
    CAN_OPEN_FAILED = 1 << 1  # was can_filter_config_failed / can_start_failed
    CAN_BUS_OFF = 1 << 2  # bus-off or unplugged: reports back off (§5.2)
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
    SPEED_SENSOR_FAULT = 1 << 21  # wheel speeds changed faster than the robot can: not used
    NOT_ARMED = 1 << 22  # power-up STOP: the mode switch has not yet passed through STOP
    CAN_AUTH_FAILED = 1 << 23  # a command failed SecOC verification ([security] on)


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
)


def flag_names(flags: int) -> list[str]:
    """The names of the set bits, lowest first; unknown bits appear as `BIT<n>`."""
    known = {flag.value: str(flag.name) for flag in ErrorFlag}
    return [known.get(1 << bit, f"BIT{bit}") for bit in range(64) if flags >> bit & 1]
