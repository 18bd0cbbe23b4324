"""The Foxglove layout shipped in docs/: the robot at a glance, built with foxglove-sdk's types.

Commands against outputs (throttle set-point against the DAC volts, steering against the servo
pulse, brake against the valve duty and speed), the mode and safety lines over time, the error
flags, the task table and the event log. `python -m bywire.telemetry.layout > FILE` writes it;
a test checks that the shipped file is this one and that every path names a schema field.
"""

from __future__ import annotations

import json

import foxglove.layouts as fl

from bywire.telemetry.schemas import EVENTS_TOPIC, STATE_TOPIC


def _plot(title: str, series: list[tuple[str, str]], right: list[tuple[str, str]]) -> fl.PlotPanel:
    """A time plot of `series` (left axis) and `right` (right axis): (field path, label)."""
    paths = [fl.PlotSeries(value=f"{STATE_TOPIC}.{path}", label=label) for path, label in series]
    paths += [
        fl.PlotSeries(value=f"{STATE_TOPIC}.{path}", label=label, use_right_y_axis=True)
        for path, label in right
    ]
    return fl.PlotPanel(title=title, config=fl.PlotConfig(paths=paths, show_legend=True))


def _state_lines() -> fl.StateTransitionsPanel:
    lines = [
        ("mode", "mode"),
        ("armed", "armed"),
        ("outputs.motors_enabled", "motors enabled"),
        ("outputs.ebrake_engaged", "e-brake engaged"),
        ("watchdog_tripped", "watchdog tripped"),
        ("error_flags_bits", "error flags (bits)"),
    ]
    series = [fl.StateTransitionsSeries(value=f"{STATE_TOPIC}.{p}", label=n) for p, n in lines]
    return fl.StateTransitionsPanel(
        title="Mode and safety", config=fl.StateTransitionsConfig(paths=series)
    )


def _mode_indicator() -> fl.IndicatorPanel:
    rules = [
        fl.IndicatorRule(raw_value="STOP", operator="=", color="#e53935", label="STOP"),
        fl.IndicatorRule(raw_value="RC", operator="=", color="#43a047", label="RC"),
        fl.IndicatorRule(raw_value="CAN", operator="=", color="#1e88e5", label="CAN"),
    ]
    config = fl.IndicatorConfig(path=f"{STATE_TOPIC}.mode", style="background", rules=rules)
    return fl.IndicatorPanel(title="Mode", config=config)


def layout() -> fl.Layout:
    commands = fl.SplitContainer(
        direction="column",
        items=[
            fl.SplitItem(content=plot)
            for plot in (
                _plot(
                    "Throttle: command and DAC",
                    [
                        ("setpoint.throttle_norm", "set-point (0-1)"),
                        ("inputs.can_movement.throttle_norm", "CAN command (0-1)"),
                        ("inputs.rc_request.throttle_norm", "RC request (0-1)"),
                    ],
                    [("outputs.dac_throttle_volts", "DAC throttle (V)")],
                ),
                _plot(
                    "Steering: command and servo",
                    [
                        ("setpoint.steering_norm", "set-point (-1..1)"),
                        ("inputs.steering_measured_norm", "measured (-1..1)"),
                    ],
                    [("outputs.steering_pulse_ms", "servo pulse (ms)")],
                ),
                _plot(
                    "Brakes and speed",
                    [
                        ("setpoint.brake_norm", "brake set-point (0-1)"),
                        ("outputs.hydrobrake_duty", "hydraulic valve duty (0-1)"),
                    ],
                    [("speed_mps", "speed (m/s)")],
                ),
            )
        ],
    )
    status = fl.SplitContainer(
        direction="column",
        items=[
            fl.SplitItem(proportion=0.5, content=_mode_indicator()),
            fl.SplitItem(content=_state_lines()),
            fl.SplitItem(
                content=fl.RawMessagesPanel(
                    title="Error flags",
                    config=fl.RawMessagesConfig(topic_path=f"{STATE_TOPIC}.error_flags"),
                )
            ),
            fl.SplitItem(
                content=fl.TablePanel(
                    title="Tasks", config=fl.TableConfig(topic_path=f"{STATE_TOPIC}.tasks")
                )
            ),
            fl.SplitItem(
                content=fl.RawMessagesPanel(
                    title="Events (mode, latches, flags)",
                    config=fl.RawMessagesConfig(topic_path=EVENTS_TOPIC),
                )
            ),
        ],
    )
    return fl.Layout(
        content=fl.SplitContainer(
            direction="row",
            items=[fl.SplitItem(proportion=2, content=commands), fl.SplitItem(content=status)],
        )
    )


def layout_json() -> str:
    """The layout as the file in docs/ holds it: indented, with a final newline."""
    return json.dumps(json.loads(layout().to_json()), indent=2) + "\n"


if __name__ == "__main__":
    print(layout_json(), end="")
