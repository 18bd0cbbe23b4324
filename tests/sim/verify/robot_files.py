"""Robot files a team might write, drawn by hypothesis: a few numbers moved within what the loader
allows and a real robot could use (`test_other_numbers.py`).

This is the suite's property over realistic numbers, which must stay green: its sub-ranges are
hand-picked. The whole legal space, every key to the ends of the range the loader itself checks,
is the product's `bywire verify --draw-robots` (`bywire.sim.verify.robots`, issue 41), whose
output is findings to fix; once those of issue 41 are fixed, this strategy should become
`draw_robot` over the loader's schema (one source of ranges)."""

from __future__ import annotations

import math

from hypothesis import strategies as st


def _seconds(low_ms: int, high_ms: int) -> st.SearchStrategy[str]:
    return st.integers(low_ms, high_ms).map(lambda ms: f"{ms / 1000:.3f}")


def _norm(low: float, high: float) -> st.SearchStrategy[str]:
    return st.integers(round(low * 100), round(high * 100)).map(lambda n: f"{n / 100:.2f}")


@st.composite
def robot_files(draw: st.DrawFn) -> str:
    """A robot file a team might write: every number moved within what the loader allows and a
    real robot could use."""
    # every deadline of config/deadlines.py kept, each with the requirement's figures: a failing
    # DAC (the driving task at 50 Hz or more) and an input loss (a task at 50 Hz or more)
    rates = [draw(st.sampled_from(choices)) for choices in ([25, 50, 100, 200], [50, 100, 200])]
    rates.append(draw(st.sampled_from([25, 50, 100, 200])))
    can_tx_hz = draw(st.sampled_from([50, 100]))
    period_s = 1.0 / max(*rates, can_tx_hz)
    # a dead wheel sensor is noticed above 0.5 m/s: the step tolerance plus 15 m/s² for a period
    step_tolerance = _norm(0.1, math.floor((0.5 - 15.0 * period_s) * 100) / 100)
    # no reversal at speed: standstill at 0.1 m/s or less; without a trusted speed the brake is
    # held at least 1.5 s (3 m/s at 2 m/s²) and no shorter than with one
    direction_dwell_ms = draw(st.integers(100, 1500))
    # the switch is judged on fresh frames: its debounce is shorter than the RC timeout
    frame_t = draw(st.integers(70, 200))  # tenths of a millisecond
    # The no-sensor brake demand gives the hydraulic duty that brakes at 2 m/s² (half of 4 m/s²
    # at full duty; config/deadlines.py, issue 41): at least halfway from the threshold to 1
    threshold = draw(st.integers(20, 80)) / 100
    demand = _norm(math.ceil((threshold + (1.0 - threshold) / 2) * 100) / 100, 1.0)
    # The steering monitor notices a servo stuck at full lock within 2 s: the slow-servo model's
    # travel (2 less the tolerance) at its speed, plus the margin
    tolerance, margin_ms = draw(st.integers(10, 30)) / 100, draw(st.integers(100, 400))
    servo_speed = _norm(math.ceil((2.0 - tolerance) / (2.0 - margin_ms / 1000) * 100) / 100, 3.0)
    # A failed hydraulic brake is noticed within 0.5 s at a duty of 0.2 or more: the duty floor
    # at 0.2 or less, the build-up time plus a decision period within 0.5 s
    response_ms = math.floor((0.5 - period_s) * 1000 + 1e-6)
    # Timeouts across the loader's ranges (INPUT_TIMEOUT_S, WATCHDOG_S): R-TIMEOUT's 100 ms and
    # R-WATCHDOG's 200 ms are defaults; a file is held to its own (oracle/test_cause_deadlines.py)
    rc_ms = draw(st.integers(max(30, frame_t // 5 + 1), 1000))
    can_ms = draw(st.integers(45, 1000))
    debounce = draw(st.integers(2, min(6, math.ceil(rc_ms * 10 / frame_t) - 1)))
    # the watchdog must outlast two periods of every task (the loader's rule) and the inputs
    watchdog_ms = draw(st.integers(max(rc_ms, can_ms, 2000 // min(rates) + 1), 5000))
    sections = {
        "timeouts": {
            "rc_timeout_s": f"{rc_ms / 1000:.3f}",
            "can_command_timeout_s": f"{can_ms / 1000:.3f}",
            "watchdog_s": f"{watchdog_ms / 1000:.3f}",
        },
        "timeouts.can_message_timeout_s": {
            name: draw(_seconds(45, can_ms))
            for name in ("ControlCommand", "MovementCommand", "LightsCommand")
        },
        "tasks": {
            "steering_rate_hz": str(rates[0]),
            "driving_rate_hz": str(rates[1]),
            "hydrobrake_rate_hz": str(rates[2]),
            "can_tx_rate_hz": str(can_tx_hz),
        },
        "sim": {"rc_frame_period_s": f"{frame_t / 10000:.4f}"},
        "supervisor": {"debounce_frames": str(debounce)},
        "interlocks": {
            "standstill_speed_mps": draw(_norm(0.02, 0.1)),
            "direction_dwell_s": f"{direction_dwell_ms / 1000:.3f}",
            "unknown_speed_dwell_s": draw(_seconds(max(1500, direction_dwell_ms), 3000)),
            "unknown_speed_brake_norm": draw(demand),
            "throttle_slew_up_per_s": draw(_norm(0.5, 5.0)),
            "speed_step_tolerance_mps": draw(step_tolerance),
        },
        "monitors": {
            "hydro_min_duty": draw(_norm(0.0, 0.2)),
            "hydro_response_s": draw(_seconds(100, response_ms)),
            "steering_tolerance_norm": f"{tolerance:.2f}",
            "steering_margin_s": f"{margin_ms / 1000:.3f}",
            "servo_speed_norm_per_s": draw(servo_speed),
        },
        "steering": {
            "rate_limit_norm_per_s": draw(_norm(2.0, 10.0)),
            "boost_gain": draw(st.sampled_from(["0.0", "0.3", "1.0"])),
            "reverse": draw(st.sampled_from(["false", "true"])),
        },
        "rc.throttle_brake": {"reverse": draw(st.sampled_from(["false", "true"]))},
        "hydrobrake": {"threshold_norm": f"{threshold:.2f}"},
        # a controlled stop demands no more than regeneration alone gives (1.5 m/s² at 5 V)
        "stop": {"controlled_min_decel_mps2": draw(_norm(0.1, 1.5))},
        "drive": {"max_throttle_volts": draw(_norm(3.0, 5.0))},
    }
    tables = [
        f"[{name}]\n" + "".join(f"{key} = {value}\n" for key, value in keys.items())
        for name, keys in sections.items()
    ]
    return 'backend = "sim"\n\n' + "\n".join(tables)
