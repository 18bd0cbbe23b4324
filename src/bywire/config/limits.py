"""What each configuration value may be: the ranges the loader checks and its messages quote."""

from __future__ import annotations

import math

from bywire.config.reader import Interval
from bywire.control.stop import MAX_CONTROLLED_STOP_S, MIN_CONTROLLED_STOP_S
from bywire.protocol import bittiming, ibus

POSITIVE_NORM_PER_S = Interval(0.0, 100.0, "norm/s", low_open=True)
HANDOVER_RATE = Interval(0.05, 2.0, "norm/s")
PULSE_S = Interval(0.0005, 0.0025, "s")
BOOST_GAIN = Interval(0.0, 2.0)
SERVO_PWM_HZ = Interval(50.0, 50.0, "Hz")
BRAKE_PWM_HZ = Interval(50.0, 20_000.0, "Hz")
PWM_CHANNELS = range(32)
RC_CHANNELS = range(ibus.CHANNEL_COUNT)  # the channels an IBUS frame carries
RC_RAW = range(800, 2201)
SWITCH_BAND_RAW = range(20, 401)  # µs either side of a switch position's nominal pulse
SWITCH_HYSTERESIS_RAW = range(0, 101)
DEADBAND_NORM = Interval(0.0, 0.5)
IBUS_BAUD = range(115_200, 115_201)
BITRATES_BPS = range(10_000, 1_000_001)
CLOCKS_HZ = range(1_000_000, 500_000_001)
SAMPLE_POINT = Interval(bittiming.SAMPLE_POINT_MIN, bittiming.SAMPLE_POINT_MAX)
I2C_BUSES = range(256)
VREF_VOLTS = Interval(0.0, 5.5, "V", low_open=True)
MOTOR_VOLTS = Interval(0.0, 5.5, "V")
THRESHOLD_NORM = Interval(0.0, 1.0, high_open=True)
BLINK_HZ = Interval(0.5, 5.0, "Hz")
INPUT_TIMEOUT_S = Interval(0.020, 1.0, "s")
WATCHDOG_S = Interval(0.020, 5.0, "s")
PASS_BUDGET_S = Interval(0.002, 0.050, "s")
STOP_RESPONSE_S = Interval(0.010, 0.060, "s")
WRITE_BUDGET_S = Interval(0.0005, 0.020, "s")
CONTROLLED_STOP_S = Interval(MIN_CONTROLLED_STOP_S, MAX_CONTROLLED_STOP_S, "s")
STOP_DECEL_MPS2 = Interval(0.1, 5.0, "m/s²")
TASK_RATE_HZ = Interval(1.0, 1000.0, "Hz")
TELEMETRY_RATE_HZ = Interval(0.1, 1000.0, "Hz")
GPIO_OFFSETS = range(1024)
SEEDS = range(2**32)
RC_FRAME_PERIOD_S = Interval(math.ceil(ibus.LINE_FRAME_S * 10_000) / 10_000, 0.1, "s")
"""The simulated receiver's period: no shorter than a frame takes on the IBUS line (2.8 ms, to
the 0.1 ms), or its frames queue up and the controller reads ever older ones (SAFETY.md row 58)."""
TOP_SPEED_MPS = Interval(0.1, 30.0, "m/s")
STANDSTILL_MPS = Interval(0.0, 1.0, "m/s")
DWELL_S = Interval(0.0, 10.0, "s")
SLEW_PER_S = Interval(0.0, 100.0, "/s", low_open=True)
DUTY = Interval(0.0, 1.0)
RESPONSE_S = Interval(0.0, 5.0, "s")
PRESSURE_BAR = Interval(0.0, 500.0, "bar", low_open=True)
TOLERANCE_NORM = Interval(0.0, 2.0)
SPEED_CHANGE_MPS2 = Interval(1.0, 100.0, "m/s²")
SPEED_STEP_MPS = Interval(0.0, 2.0, "m/s")
DEBOUNCE_FRAMES = range(2, 51)
DEBOUNCE_WHY = (
    "one frame is no debounce: a mode switch bouncing through STOP would re-arm the robot,"
    " SAFETY.md row 26"
)
FIFO_PRIORITY = range(1, 99)  # 99 is left to the kernel's own watchdog and migration threads
CPU_NUMBERS = range(1024)
