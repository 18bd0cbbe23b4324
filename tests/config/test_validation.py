"""Validation: a bad value is refused naming its dotted key, value, allowed range and file."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.config import GpioLine, RobotConfig, as_dict, parse_config
from bywire.errors import ConfigError
from tests.config.toml_keys import leaf_keys

ORIGIN = "robot.toml"


def _refusal(text: str) -> str:
    with pytest.raises(ConfigError) as caught:
        parse_config(text, ORIGIN)
    return str(caught.value)


# (TOML text, the dotted key the message must name, the allowed range or values it must quote)
BAD_VALUES = [
    ('name = ""', "name", "non-empty string"),
    ('backend = "linx"', "backend", '"sim", "linux"'),
    ("gpio_chip = 0", "gpio_chip", "got an integer"),
    ("can = 3", "can", "expected a table [can]"),
    ('[can]\ninterface = "socketcann"', "can.interface", '"socketcan"'),
    ('[can]\nchannel = ""', "can.channel", "non-empty string"),
    ("[can]\nbitrate_bps = 9999", "can.bitrate_bps", "10000..1000000"),
    ("[can]\nbitrate_bps = 1000001", "can.bitrate_bps", "10000..1000000"),
    ("[can]\nbitrate_bps = 500000.0", "can.bitrate_bps", "an integer in 10000..1000000"),
    ("[can]\nsample_point = 0.4", "can.sample_point", "0.5..0.95"),
    ("[can]\nclock_hz = 100", "can.clock_hz", "1000000..500000000"),
    (
        "[can]\nclock_hz = 42_000_000\nbitrate_bps = 800_000",
        "can.bitrate_bps",
        "1000000, 500000, 250000",
    ),
    ("[rc]\nport = 1", "rc.port", "got an integer"),
    ("[rc]\nbaud = 9600", "rc.baud", "only 115200"),
    ("[rc.steering]\nchannel = 14", "rc.steering.channel", "0..13"),
    ("[rc.steering]\nchannel = -1", "rc.steering.channel", "0..13"),
    ("[rc.steering]\nchannel = true", "rc.steering.channel", "got a boolean"),
    ("[rc.steering]\nmin_raw = 799", "rc.steering.min_raw", "800..2200"),
    ("[rc.steering]\ncenter_raw = 2201", "rc.steering.center_raw", "800..2200"),
    ("[rc.steering]\nmax_raw = 2201", "rc.steering.max_raw", "800..2200"),
    ("[rc.steering]\ndeadband_norm = 0.6", "rc.steering.deadband_norm", "0..0.5"),
    ("[rc.steering]\ndeadband_norm = -0.1", "rc.steering.deadband_norm", "0..0.5"),
    ("[rc.steering]\nreverse = 1", "rc.steering.reverse", "true or false"),
    ("[rc.throttle_brake]\nmin_raw = 1500", "rc.throttle_brake.min_raw", "min < center < max"),
    ("[rc.throttle_brake]\nmax_raw = 1500", "rc.throttle_brake.max_raw", "min < center < max"),
    ("[rc.mode_switch]\nchannel = 0", "rc.mode_switch.channel", "give each its own"),
    ('[rc.hazard_switch]\nreverse = "yes"', "rc.hazard_switch.reverse", "true or false"),
    ("[steering]\nmin_pulse_s = 0.0004", "steering.min_pulse_s", "0.0005..0.0025 s"),
    ("[steering]\nmax_pulse_s = 0.0026", "steering.max_pulse_s", "0.0005..0.0025 s"),
    ("[steering]\ncenter_pulse_s = 0.002", "steering.center_pulse_s", "min < center < max"),
    ("[steering]\nmin_pulse_s = 0.0015", "steering.min_pulse_s", "min < center < max"),
    ("[steering]\nreverse = 0", "steering.reverse", "true or false"),
    ("[steering]\nrate_limit_norm_per_s = 0", "steering.rate_limit_norm_per_s", "> 0 and <= 100"),
    ("[steering]\nservo_speed_norm_per_s = inf", "steering.servo_speed_norm_per_s", "<= 100"),
    ("[steering]\nboost_gain = 2.5", "steering.boost_gain", "0..2"),
    ("[steering]\nboost_gain = -0.1", "steering.boost_gain", "0..2"),
    ("[steering]\nboost_gain = nan", "steering.boost_gain", "0..2"),
    ("[steering.pwm]\nfrequency_hz = 60", "steering.pwm.frequency_hz", "only 50 Hz"),
    ("[steering.pwm]\nchannel = 32", "steering.pwm.channel", "0..31"),
    ('[steering.pwm]\nchip = ""', "steering.pwm.chip", "non-empty string"),
    ("[hydrobrake]\nthreshold_norm = 1.0", "hydrobrake.threshold_norm", ">= 0 and < 1"),
    ("[hydrobrake]\nthreshold_norm = -0.1", "hydrobrake.threshold_norm", ">= 0 and < 1"),
    ("[hydrobrake.pwm]\nfrequency_hz = 40", "hydrobrake.pwm.frequency_hz", "50..20000 Hz"),
    ("[hydrobrake.pwm]\nfrequency_hz = 20001", "hydrobrake.pwm.frequency_hz", "50..20000 Hz"),
    ("[hydrobrake.pwm]\nchannel = 0", "hydrobrake.pwm", "steering.pwm"),
    ("[drive]\nmax_throttle_volts = 5.6", "drive.max_throttle_volts", "0..5.5 V"),
    ("[drive]\nmax_regen_volts = -1", "drive.max_regen_volts", "0..5.5 V"),
    (
        "[drive]\nmax_throttle_volts = 4\nmax_regen_volts = 4.5\n[drive.dac]\nvref_volts = 4",
        "drive.max_regen_volts = 4.5",
        "0..4 V",
    ),
    ("[drive.dac]\ni2c_bus = 256", "drive.dac.i2c_bus", "0..255"),
    ("[drive.dac]\naddress = 0x4B", "drive.dac.address = 0x4B", "0x4C..0x4F"),
    ("[drive.dac]\naddress = 0x50", "drive.dac.address = 0x50", "0x4C..0x4F"),
    ('[drive.dac]\nbackend = "iio"', "drive.dac.backend", '"auto"'),
    ("[drive.dac]\nvref_volts = 0", "drive.dac.vref_volts", "> 0 and <= 5.5 V"),
    ("[drive.dac]\nthrottle_channel = 4", "drive.dac.throttle_channel", "0..3"),
    ("[drive.dac]\nregen_channel = 0", "drive.dac.regen_channel", "give each its own"),
    ("[drive]\nmotors_enable = true", "drive.motors_enable", "line name (string)"),
    ("[drive]\nmotors_forward = 1024", "drive.motors_forward = 1024: out of range", "0..1023"),
    ('[drive]\nmotors_reverse = { chip = "gpiochip1" }', "drive.motors_reverse.line", "missing"),
    ("[drive]\nmotors_reverse = { line = 3, pin = 4 }", "drive.motors_reverse.pin", "known keys"),
    ('[ebrake]\nebrake_release = ""', "ebrake.ebrake_release", "line name"),
    ("[lights]\nblink_rate_hz = 0.1", "lights.blink_rate_hz", "0.5..5 Hz"),
    ('[lights]\nbrake_light = "MOTORS_ENABLE"', "lights.brake_light", "drive.motors_enable"),
    ("[lights]\nlow_beam = [1]", "lights.low_beam", "got an array"),
    ("[timeouts]\nrc_timeout_s = 0.019", "timeouts.rc_timeout_s", "0.02..1 s"),
    ("[timeouts]\nrc_timeout_s = 1.5", "timeouts.rc_timeout_s", "0.02..1 s"),
    ("[timeouts]\ncan_command_timeout_s = 0", "timeouts.can_command_timeout_s", "0.02..1 s"),
    ("[timeouts]\nwatchdog_s = 0.01", "timeouts.watchdog_s", "0.02..5 s"),
    ("[interlocks]\nthrottle_slew_up_per_s = 0", "interlocks.throttle_slew_up_per_s", "/s"),
    ("[interlocks]\ndirection_dwell_s = 11", "interlocks.direction_dwell_s", "0..10 s"),
    ("[monitors]\nhydro_min_duty = 1.5", "monitors.hydro_min_duty", "0..1"),
    ("[monitors]\nhydro_response_s = -1", "monitors.hydro_response_s", "0..5 s"),
    (
        "[timeouts]\nwatchdog_s = 0.1\n[tasks]\nsteering_rate_hz = 10",
        "timeouts.watchdog_s",
        ">= 0.2 s",
    ),
    ("[tasks]\nsteering_rate_hz = 0.5", "tasks.steering_rate_hz", "1..1000 Hz"),
    ("[tasks]\ndriving_rate_hz = 1001", "tasks.driving_rate_hz", "1..1000 Hz"),
    ('[tasks]\ncan_tx_rate_hz = "50"', "tasks.can_tx_rate_hz", "a number in 1..1000 Hz"),
    ("[tasks]\nlights_rate_hz = true", "tasks.lights_rate_hz", "got a boolean"),
    ("[tasks]\nhydrobrake_rate_hz = 0", "tasks.hydrobrake_rate_hz", "1..1000 Hz"),
    ('[realtime]\nscheduler = "rr"', "realtime.scheduler", '"other", "fifo"'),
    ("[realtime]\npriority = 99", "realtime.priority", "1..98"),
    ("[realtime]\nlock_memory = 1", "realtime.lock_memory", "true or false"),
    ('[realtime]\ncpus = "1-"', "realtime.cpus", "not a CPU list"),
    ('[realtime]\ncpus = "3-1"', "realtime.cpus", "not a CPU list"),
    ('[realtime]\ncpus = ""', "realtime.cpus", '"all" or a CPU list'),
    ('[realtime]\ncpus = "1024"', "realtime.cpus", "CPUs 0..1023"),
    ("[realtime]\ncpus = 1", "realtime.cpus", "got an integer"),
    ('[realtime]\ngc_mode = "off"', "realtime.gc_mode", '"automatic", "idle"'),
    ("[realtime]\ngc_freeze = 0", "realtime.gc_freeze", "true or false"),
    ("[telemetry]\nrate_hz = 0", "telemetry.rate_hz", "0.1..1000 Hz"),
    ('[telemetry]\nmcap = "run.txt"', "telemetry.mcap", "ends in .mcap"),
    ('[telemetry]\nfoxglove = "0.0.0.0:8765"', "telemetry.foxglove", "allow_remote = true"),
    ('[telemetry]\nfoxglove = "192.168.1.5:8765"', "telemetry.foxglove", "loopback only"),
    ('[telemetry]\nfoxglove = "robot"', "telemetry.foxglove", "[HOST:]PORT"),
    ('[telemetry]\nfoxglove = "70000"', "telemetry.foxglove", "0..65535"),
    ("[sim]\nseed = -1", "sim.seed", "0..4294967295"),
    ("[sim]\nrc_frame_period_s = 0.5", "sim.rc_frame_period_s", "0.0028..0.1 s"),
    ("[sim]\ntop_speed_mps = 0", "sim.top_speed_mps", "0.1..30 m/s"),
    ("[vehicle]\nwheelbase_m = 0.05", "vehicle.wheelbase_m", "0.1..10 m"),
    ("[vehicle]\nwheelbase_m = 11", "vehicle.wheelbase_m", "0.1..10 m"),
    ("[vehicle]\ntrack_m = 0", "vehicle.track_m", "0.1..5 m"),
    ("[vehicle]\nmax_steering_angle_deg = 90", "vehicle.max_steering_angle_deg", "1..60 °"),
    ("[vehicle]\nmax_steering_angle_deg = 0.5", "vehicle.max_steering_angle_deg", "1..60 °"),
    ("[steering]\nmax_pulse = 0.002", "steering.max_pulse", "did you mean steering.max_pulse_s"),
    ("[steerin]\nmax_pulse_s = 0.002", "steerin", "did you mean steering"),
    ("colour = 1", "colour", "unknown key"),
]


@pytest.mark.parametrize(("text", "key", "allowed"), BAD_VALUES, ids=[c[0] for c in BAD_VALUES])
def test_bad_value_is_refused_with_key_range_and_file(text: str, key: str, allowed: str) -> None:
    message = _refusal(text)
    assert message.startswith(f"{ORIGIN}: ")
    assert key in message
    assert allowed in message
    assert "problems:" not in message  # one bad value, one problem: no knock-on errors


ARRAY_KEYS = {"telemetry.allowed_origins"}  # an array is right there: the wrong type is another
EVERY_KEY = [
    *leaf_keys(as_dict(RobotConfig())),
    "can.clock_hz",
    "telemetry.mcap",
    "telemetry.foxglove",
]


@pytest.mark.parametrize("key", EVERY_KEY)
def test_every_key_refuses_a_value_of_the_wrong_type(key: str) -> None:
    section, _, name = key.rpartition(".")
    header = f"[{section}]\n" if section else ""
    wrong, got = ("1", "an integer") if key in ARRAY_KEYS else ("[]", "an array")
    message = _refusal(f"{header}{name} = {wrong}")
    assert f"{key} = {wrong}: expected" in message
    assert f"got {got}" in message
    assert "problems:" not in message


def test_message_quotes_the_bad_value() -> None:
    message = _refusal("[steering]\nmax_pulse_s = 0.003")
    assert message == (
        "robot.toml: steering.max_pulse_s = 0.003: out of range; allowed 0.0005..0.0025 s"
    )


def test_a_one_frame_debounce_is_refused_with_the_hazard_it_would_open() -> None:
    """Found by `bywire verify` on a robot file with `debounce_frames = 1`: a switch that bounced
    through STOP for one frame re-armed the robot (H1) and acknowledged a watchdog trip (H3)."""
    message = _refusal("[supervisor]\ndebounce_frames = 1")
    assert message.startswith(
        "robot.toml: supervisor.debounce_frames = 1: out of range; allowed 2..50 (one frame is no"
        " debounce: a mode switch bouncing through STOP would re-arm the robot"
    )
    assert "row 26" in message
    assert parse_config("[supervisor]\ndebounce_frames = 2").supervisor.debounce_frames == 2


def test_several_problems_are_reported_together() -> None:
    message = _refusal("[rc]\nbaud = 9600\n[steering]\nboost_gain = 3\nmax_pulse = 1")
    assert message.startswith("robot.toml: 3 problems:\n")
    for key in ("rc.baud", "steering.boost_gain", "steering.max_pulse"):
        assert key in message


def test_ints_are_accepted_where_floats_are_expected() -> None:
    config = parse_config("[tasks]\nsteering_rate_hz = 200\n[drive.dac]\nvref_volts = 5")
    assert config.tasks.rate_hz("steering") == 200.0
    assert isinstance(config.tasks.rate_hz("steering"), float)
    assert isinstance(config.drive.dac.vref_volts, float)


def test_lowering_vref_without_the_limits_is_refused_for_both_limits() -> None:
    message = _refusal("[drive.dac]\nvref_volts = 4")
    assert "drive.max_throttle_volts = 5.0" in message
    assert "drive.max_regen_volts = 5.0" in message
    assert "allowed 0..4 V" in message


def test_exact_bx_can_bit_timing_is_accepted() -> None:
    config = parse_config("[can]\nclock_hz = 48_000_000\nbitrate_bps = 500_000")
    assert (config.can.clock_hz, config.can.bitrate_bps) == (48_000_000, 500_000)


def test_unreachable_bitrate_on_the_clock_names_the_key() -> None:
    message = _refusal("[can]\nclock_hz = 1_000_000\nbitrate_bps = 1_000_000")
    assert "can.bitrate_bps = 1000000 with can.clock_hz = 1000000" in message
    assert "bitrate must be" in message


def test_gpio_line_forms_and_the_default_chip() -> None:
    config = parse_config(
        'gpio_chip = "pinctrl-bcm2711"\n[lights]\nbrake_light = 22\nlow_beam = "GPIO26"\n'
        'error_led = { chip = "/dev/gpiochip4", line = 7 }'
    )
    lights = config.lights
    assert lights.brake_light == GpioLine("pinctrl-bcm2711", 22)
    assert lights.low_beam == GpioLine("pinctrl-bcm2711", "GPIO26")
    assert lights.error_led == GpioLine("/dev/gpiochip4", 7)
    assert lights.reverse_light == GpioLine("pinctrl-bcm2711", "REVERSE_LIGHT")


def test_same_offset_on_different_chips_is_not_a_clash() -> None:
    config = parse_config(
        '[drive]\nmotors_enable = 5\n[lights]\nbrake_light = { chip = "gpiochip1", line = 5 }'
    )
    assert config.drive.motors_enable.line == config.lights.brake_light.line == 5


def test_rc_mapping_is_the_control_layers_type_with_toml_values() -> None:
    config = parse_config("[rc.steering]\nchannel = 3\nreverse = true\n[rc.gear_switch]\nchannel=9")
    mapping = config.rc.mapping
    assert (mapping.steering.channel, mapping.steering.reverse) == (3, True)
    assert mapping.gear_switch.channel == 9
    assert mapping.mode_positions == RobotConfig().rc.mapping.mode_positions


PULSE = st.floats(0.0005, 0.0025)
TIMEOUT = st.floats(0.024, 1.0)  # above the switch debounce (3 frames of 7.7 ms)
OUTSIDE_TIMEOUT = st.one_of(
    st.floats(max_value=0.0199), st.floats(min_value=1.0001), st.just(math.nan)
)


@given(st.lists(PULSE, min_size=3, max_size=3, unique=True))
def test_any_increasing_in_range_pulses_load(pulses: list[float]) -> None:
    low, center, high = sorted(pulses)
    text = f"[steering]\nmin_pulse_s = {low!r}\ncenter_pulse_s = {center!r}\nmax_pulse_s = {high!r}"
    servo = parse_config(text).steering.servo
    assert (servo.min_pulse_s, servo.center_pulse_s, servo.max_pulse_s) == (low, center, high)


@given(st.one_of(st.floats(max_value=0.000499), st.floats(min_value=0.002501)))
def test_any_out_of_range_pulse_is_refused(pulse_s: float) -> None:
    message = _refusal(f"[steering]\nmax_pulse_s = {_toml_float(pulse_s)}")
    assert "steering.max_pulse_s" in message
    assert "0.0005..0.0025 s" in message


CAN_TIMEOUT = st.floats(0.040, 1.0)  # at least two 20 ms periods of every command (the DBC)


@given(TIMEOUT, CAN_TIMEOUT)
def test_any_in_range_timeouts_load(rc_s: float, can_s: float) -> None:
    text = (
        f"[timeouts]\nrc_timeout_s = {rc_s!r}\ncan_command_timeout_s = {can_s!r}\n"
        "watchdog_s = 1.0\n"  # no input may drive on longer than a stalled loop would
    )
    timeouts = parse_config(text).timeouts
    assert (timeouts.rc_timeout_s, timeouts.can_command_timeout_s) == (rc_s, can_s)
    assert {timeout_s for _, timeout_s in timeouts.can_message_timeout_s} == {can_s}


@given(st.floats(0.020, 0.0399))
def test_a_can_timeout_shorter_than_two_dbc_periods_is_refused(can_s: float) -> None:
    message = _refusal(f"[timeouts]\ncan_command_timeout_s = {can_s!r}")
    assert "timeouts.can_command_timeout_s" in message
    assert "ControlCommand, MovementCommand, LightsCommand" in message
    assert "GenMsgCycleTime" in message
    assert "allowed >= 0.04 s" in message


@pytest.mark.parametrize("rate_hz", [1, 20, 49.9])
def test_reports_slower_than_their_dbc_period_are_refused(rate_hz: float) -> None:
    message = _refusal(f"[tasks]\ncan_tx_rate_hz = {rate_hz}")
    assert "tasks.can_tx_rate_hz" in message
    assert "GenMsgCycleTime" in message
    assert "allowed >= 50 Hz" in message


@pytest.mark.parametrize("rate_hz", [50, 100])
def test_reports_at_or_above_their_dbc_rate_are_taken(rate_hz: int) -> None:
    assert parse_config(f"[tasks]\ncan_tx_rate_hz = {rate_hz}").tasks.rate_hz("can_tx") == rate_hz


def test_a_message_named_gets_its_own_timeout_and_the_others_the_default() -> None:
    text = (
        "[timeouts]\ncan_command_timeout_s = 0.08\n"
        "[timeouts.can_message_timeout_s]\nLightsCommand = 0.4"
    )
    timeouts = parse_config(text).timeouts
    assert timeouts.can_timeout_s("LightsCommand") == 0.4
    assert timeouts.can_timeout_s("MovementCommand") == 0.08
    assert timeouts.can_timeout_s("ControlCommand") == 0.08


def test_a_message_timeout_is_refused_under_its_own_key() -> None:
    message = _refusal("[timeouts.can_message_timeout_s]\nMovementCommand = 0.03")
    assert message.count("timeouts.can_message_timeout_s.MovementCommand = 0.03") == 1
    assert "allowed >= 0.04 s" in message
    assert "can_command_timeout_s =" not in message


def test_a_message_the_dbc_does_not_command_is_refused_with_the_names_it_knows() -> None:
    message = _refusal("[timeouts.can_message_timeout_s]\nMovementComand = 0.2")
    assert "timeouts.can_message_timeout_s.MovementComand" in message
    assert "did you mean timeouts.can_message_timeout_s.MovementCommand?" in message
    assert "known keys: ControlCommand, MovementCommand, LightsCommand" in message


@given(OUTSIDE_TIMEOUT)
def test_any_out_of_range_timeout_is_refused(timeout_s: float) -> None:
    message = _refusal(f"[timeouts]\ncan_command_timeout_s = {_toml_float(timeout_s)}")
    assert "timeouts.can_command_timeout_s" in message
    assert "0.02..1 s" in message


def _toml_float(value: float) -> str:
    return {math.inf: "inf", -math.inf: "-inf"}.get(
        value, "nan" if math.isnan(value) else repr(value)
    )


@pytest.mark.parametrize(
    ("text", "cpus"),
    [("all", None), ("1", {1}), ("0-1", {0, 1}), ("0, 2-3", {0, 2, 3}), ("5-5", {5})],
)
def test_realtime_cpus_are_a_cpu_list_as_taskset_writes_it(
    text: str, cpus: set[int] | None
) -> None:
    config = parse_config(f'[realtime]\ncpus = "{text}"')
    assert config.realtime.cpus == text
    assert config.realtime.cpu_set == (None if cpus is None else frozenset(cpus))


def test_realtime_defaults_need_no_privilege() -> None:
    realtime = RobotConfig().realtime
    assert (realtime.scheduler, realtime.lock_memory, realtime.cpu_set) == ("other", False, None)
    assert realtime.gc_freeze


def test_a_remote_telemetry_address_needs_allow_remote() -> None:
    config = parse_config('[telemetry]\nfoxglove = "0.0.0.0:8765"\nallow_remote = true')
    assert (config.telemetry.foxglove, config.telemetry.allow_remote) == ("0.0.0.0:8765", True)
    assert parse_config('[telemetry]\nfoxglove = "8765"').telemetry.foxglove == "8765"


@pytest.mark.parametrize(
    "value",
    ['"https://app.foxglove.dev"', '["app.foxglove.dev"]', '["https://x/path"]', "[1]", '["null"]'],
)
def test_allowed_origins_are_origins(value: str) -> None:
    with pytest.raises(ConfigError, match=r"telemetry\.allowed_origins = .*expected an array of"):
        parse_config(f"[telemetry]\nallowed_origins = {value}\n")
    section = parse_config('[telemetry]\nallowed_origins = ["https://app.foxglove.dev"]\n')
    assert section.telemetry.allowed_origins == ("https://app.foxglove.dev",)
