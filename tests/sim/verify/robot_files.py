"""Robot files a team might write, drawn by hypothesis: a few numbers moved within what the loader
allows and a real robot could use (`test_other_numbers.py`).

This is the suite's property over realistic numbers, which must stay green: its sub-ranges are
hand-picked. The whole legal space, every key to the ends of the range the loader itself checks,
is the product's `bywire verify --draw-robots` (`bywire.sim.verify.robots`, issue 41), whose
output is findings to fix; once those of issue 41 are fixed, this strategy should become
`draw_robot` over the loader's schema (one source of ranges)."""

from __future__ import annotations

from hypothesis import strategies as st


def _seconds(low_ms: int, high_ms: int) -> st.SearchStrategy[str]:
    return st.integers(low_ms, high_ms).map(lambda ms: f"{ms / 1000:.3f}")


def _norm(low: float, high: float) -> st.SearchStrategy[str]:
    return st.integers(round(low * 100), round(high * 100)).map(lambda n: f"{n / 100:.2f}")


@st.composite
def robot_files(draw: st.DrawFn) -> str:
    """A robot file a team might write: every number moved within what the loader allows and a
    real robot could use."""
    rates = [draw(st.sampled_from([25, 50, 100, 200])) for _ in range(3)]
    # Timeouts across the loader's ranges (INPUT_TIMEOUT_S, WATCHDOG_S): R-TIMEOUT's 100 ms and
    # R-WATCHDOG's 200 ms are defaults; a file is held to its own (oracle/test_cause_deadlines.py)
    rc_ms, can_ms = draw(st.integers(30, 1000)), draw(st.integers(45, 1000))
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
            "can_tx_rate_hz": draw(st.sampled_from(["50", "100"])),
        },
        "sim": {"rc_frame_period_s": draw(st.integers(70, 200).map(lambda t: f"{t / 10000:.4f}"))},
        "supervisor": {"debounce_frames": str(draw(st.integers(2, 6)))},
        "interlocks": {
            "standstill_speed_mps": draw(_norm(0.02, 0.2)),
            "direction_dwell_s": draw(_seconds(100, 1500)),
            "unknown_speed_dwell_s": draw(_seconds(500, 3000)),
            "unknown_speed_brake_norm": draw(_norm(0.5, 1.0)),
            "throttle_slew_up_per_s": draw(_norm(0.5, 5.0)),
            "speed_step_tolerance_mps": draw(_norm(0.1, 0.5)),
        },
        "monitors": {
            "hydro_min_duty": draw(_norm(0.1, 0.4)),
            "hydro_response_s": draw(_seconds(100, 500)),
            "steering_tolerance_norm": draw(_norm(0.1, 0.3)),
            "steering_margin_s": draw(_seconds(100, 400)),
        },
        "steering": {
            "rate_limit_norm_per_s": draw(_norm(2.0, 10.0)),
            "boost_gain": draw(st.sampled_from(["0.0", "0.3", "1.0"])),
            "reverse": draw(st.sampled_from(["false", "true"])),
        },
        "rc.throttle_brake": {"reverse": draw(st.sampled_from(["false", "true"]))},
        "hydrobrake": {"threshold_norm": draw(_norm(0.2, 0.8))},
        "drive": {"max_throttle_volts": draw(_norm(3.0, 5.0))},
    }
    tables = [
        f"[{name}]\n" + "".join(f"{key} = {value}\n" for key, value in keys.items())
        for name, keys in sections.items()
    ]
    return 'backend = "sim"\n\n' + "\n".join(tables)
