"""A PNG of a CAN log: commands, actuator state, speed and mode over time (R-PLOT).

What the bus shows of a run, drawn like `bywire sim --plot`: the higher-level computer's
movement set-points, the steering the controller commanded and measured, the wheel speeds, the
lights and the number of error flags, and the control mode with the e-brake and the STOP latch.
"""

from __future__ import annotations

import math
from pathlib import Path

from matplotlib.axes import Axes
from matplotlib.figure import Figure

from bywire.errors import ConfigError
from bywire.model import ControlMode
from bywire.sim.plot import DPI, SIZE_IN
from bywire.tools.log_decode import DecodedLog, Signal

LIGHTS = ("brake", "reverse", "turn_left", "turn_right", "hazard", "low_beam", "error_led")
LANE_HEIGHT = 0.8


def _lines(axes: Axes, log: DecodedLog, unit: str, **series: str) -> None:
    """One line per signal (label=Message.signal), drawn as held between frames."""
    for label, name in series.items():
        signal = log.signal(name)
        axes.step(signal.times_s, signal.values, where="post", label=label, lw=1.2)
    axes.set_ylabel(unit)
    axes.grid(alpha=0.3)


def _where_valid(log: DecodedLog, name: str, valid_name: str) -> Signal:
    """A signal with a gap (NaN) wherever its validity bit, sent in the same frame, is clear."""
    signal, valid = log.signal(name), log.signal(valid_name)
    values = [v if ok else math.nan for v, ok in zip(signal.values, valid.values, strict=False)]
    return Signal(signal.times_s[: len(values)], tuple(values))


def _legend(axes: Axes, *more: Axes) -> None:
    """One legend right of the panel, twin axis lines included (as the sim's plot does)."""
    handles, labels = axes.get_legend_handles_labels()
    for other in more:
        extra_handles, extra_labels = other.get_legend_handles_labels()
        handles, labels = handles + extra_handles, labels + extra_labels
    if handles:
        axes.legend(handles, labels, loc="upper left", bbox_to_anchor=(1.07, 1.0), fontsize="small")


def _lanes(axes: Axes, lanes: dict[str, Signal], first: int = 0) -> list[float]:
    """Logic-analyser lanes, one per boolean signal, from `first` up; their label heights."""
    colours = ("tab:red", "tab:orange", "tab:green", "tab:olive", "tab:brown", "tab:blue", "k")
    for index, (label, signal) in enumerate(lanes.items()):
        base = first + index
        tops = [base + LANE_HEIGHT * bool(value) for value in signal.values]
        colour = colours[index % len(colours)]
        axes.fill_between(
            signal.times_s, base, tops, step="post", color=colour, alpha=0.5, lw=0, label=label
        )
    return [first + index + LANE_HEIGHT / 2 for index in range(len(lanes))]


def _lights_panel(axes: Axes, log: DecodedLog) -> Axes:
    heights = _lanes(axes, {name: log.signal(f"LightsReport.{name}") for name in LIGHTS})
    axes.set_yticks(heights, [name.replace("_", " ") for name in LIGHTS])
    axes.set_ylim(-0.2, len(LIGHTS))
    axes.grid(alpha=0.3, axis="x")
    flags = log.signal("ErrorReport.flags")
    twin = axes.twinx()
    counts = [int(value).bit_count() for value in flags.values]
    twin.step(flags.times_s, counts, where="post", color="tab:purple", ls="--", label="error flags")
    twin.set_ylabel("error flags set")
    twin.set_ylim(bottom=0)
    return twin


def _mode_panel(axes: Axes, log: DecodedLog) -> None:
    """The STOP/RC/CAN step line above lanes for the e-brake and the STOP latch."""
    lanes = {
        "e-brake engaged": log.signal("ModeReport.estop_engaged"),
        "STOP latched": log.signal("ModeReport.stop_latched"),
    }
    heights = _lanes(axes, lanes)
    mode = log.signal("ModeReport.control_mode")
    axes.step(
        mode.times_s, [2 + value for value in mode.values], where="post", color="black", lw=1.5
    )
    modes = sorted(ControlMode, key=lambda m: m.value)
    axes.set_yticks(
        [*heights, *(2 + m.value for m in modes)], ["e-brake", "latched", *(m.name for m in modes)]
    )
    axes.set_ylim(-0.2, 2 + max(m.value for m in modes) + 0.5)
    axes.set_ylabel("mode")
    axes.grid(alpha=0.3, axis="x")
    _legend(axes)


def draw_log(log: DecodedLog, title: str) -> Figure:
    """The figure: five panels over the log's time."""
    figure = Figure(figsize=SIZE_IN, dpi=DPI, layout="constrained")
    command, steering, speed, lights, mode = figure.subplots(5, 1, sharex=True)
    movement = "MovementCommand."
    _lines(
        command,
        log,
        "command (norm)",
        steering=movement + "steering_norm",
        throttle=movement + "throttle_norm",
        brake=movement + "brake_norm",
    )
    _legend(command)
    _lines(steering, log, "steering (norm)", commanded="SteeringReport.commanded_norm")
    measured = _where_valid(log, "SteeringReport.measured_norm", "SteeringReport.measured_valid")
    steering.step(measured.times_s, measured.values, where="post", label="measured", lw=1.2)
    _legend(steering)
    wheels = "WheelSpeedReport."
    _lines(speed, log, "speed (m/s)", left=wheels + "left_mps", right=wheels + "right_mps")
    _legend(speed)
    _legend(lights, _lights_panel(lights, log))
    _mode_panel(mode, log)
    mode.set_xlabel("time (s)")
    mode.set_xlim(0.0, max(log.duration_s, 1e-3))
    figure.suptitle(title, fontsize=11)
    return figure


def write_log_plot(log: DecodedLog, path: Path, title: str) -> None:
    """Draw `log` into one PNG at `path`; ConfigError when it cannot be written."""
    if path.suffix.lower() != ".png":
        raise ConfigError(f"cannot write a plot as {path.name!r}: the suffix must be .png")
    if not path.parent.is_dir():
        raise ConfigError(f"cannot write {path}: folder {path.parent} does not exist")
    figure = draw_log(log, title)
    try:
        figure.savefig(path, dpi=DPI)
    except OSError as error:
        raise ConfigError(f"cannot write {path}: {error.strerror}") from error
