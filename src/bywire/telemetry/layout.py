"""The Foxglove layout shipped in docs/: the robot at a glance, built with foxglove-sdk's types.

Commands against outputs (throttle set-point against the DAC volts, steering against the servo
pulse, brake against the valve duty and speed) and the CAN commands decoded with the DBC, the mode
and safety lines and the error flags by name over time, the simulated vehicle's path in 3D, the
task table and the event log (foxglove.Log). `python -m bywire.telemetry.layout > FILE` writes it;
a test checks that the shipped file is this one and that every path names a schema field.
"""

from __future__ import annotations

import json

import foxglove.layouts as fl

from bywire.telemetry.foxglove_topics import (
    CAN_MESSAGES_PREFIX,
    FLAGS_TOPIC,
    LOG_TOPIC,
    POSE_TOPIC,
    ROBOT_FRAME,
    WORLD_FRAME,
)
from bywire.telemetry.schemas import STATE_TOPIC


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


def _can_plot() -> fl.PlotPanel:
    """The higher-level computer's commands as the DBC decodes them off the bus."""
    movement = f"{CAN_MESSAGES_PREFIX}MovementCommand"
    series = [
        fl.PlotSeries(value=f"{movement}.{signal}", label=f"MovementCommand.{signal}")
        for signal in ("throttle_norm", "brake_norm", "steering_norm")
    ]
    return fl.PlotPanel(
        title="CAN, decoded with albert.dbc", config=fl.PlotConfig(paths=series, show_legend=True)
    )


def _flag_lines() -> fl.StateTransitionsPanel:
    """The flags that stop the robot, each by name over time."""
    names = (
        "NOT_ARMED",
        "RC_TIMEOUT",
        "RC_FAILSAFE",
        "CAN_COMMAND_TIMEOUT",
        "CAN_COMMAND_REJECTED",
        "CAN_UNTRUSTED",
        "REMOTE_STOP",
        "WATCHDOG_TRIPPED",
        "DAC_FAULT_STOP",
    )
    series = [fl.StateTransitionsSeries(value=f"{FLAGS_TOPIC}.{n}", label=n) for n in names]
    return fl.StateTransitionsPanel(
        title="Error flags by name", config=fl.StateTransitionsConfig(paths=series)
    )


def _robot_3d() -> fl.ThreeDeePanel:
    """The simulated vehicle's path (bywire sim): its pose in the world frame, followed."""
    pose = fl.BaseRendererPoseTopicSettings(visible=True, type="arrow")
    return fl.ThreeDeePanel(
        title="Simulated vehicle",
        config=fl.ThreeDeeConfig(
            topics={POSE_TOPIC: pose}, fixed_frame=WORLD_FRAME, follow_tf=ROBOT_FRAME
        ),
    )


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
                _can_plot(),
            )
        ],
    )
    status = fl.SplitContainer(
        direction="column",
        items=[
            fl.SplitItem(proportion=0.5, content=_mode_indicator()),
            fl.SplitItem(content=_state_lines()),
            fl.SplitItem(content=_flag_lines()),
            fl.SplitItem(content=_robot_3d()),
            fl.SplitItem(
                content=fl.TablePanel(
                    title="Tasks", config=fl.TableConfig(topic_path=f"{STATE_TOPIC}.tasks")
                )
            ),
            fl.SplitItem(
                content=fl.LogPanel(
                    title="Events (mode, latches, flags)",
                    config=fl.LogConfig(topic_to_render=LOG_TOPIC, show_level=True),
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
