"""A PNG of a simulated run: commands, actuator outputs, speed and mode over time (R-PLOT).

matplotlib is imported when a plot is drawn, not when this module is: `bywire sim` imports it
for `--plot`, and loading matplotlib took 0.4 s and 45 MB of every run that draws nothing.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from bywire.errors import ConfigError
from bywire.model import ControlMode
from bywire.sim.observe import Observation
from bywire.sim.runner import SimRun

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

SIZE_IN = (11.0, 12.0)
DPI = 100
Line = tuple[str, Callable[[Observation], float]]  # label, value


def check_plot_path(path: Path) -> None:
    """ConfigError unless `path` is a .png in an existing folder."""
    if path.suffix.lower() != ".png":
        raise ConfigError(f"cannot write a plot as {path.name!r}: the suffix must be .png")
    if not path.parent.is_dir():
        raise ConfigError(f"cannot write {path}: folder {path.parent} does not exist")


def _lines(axes: Axes, times_s: list[float], samples: list[Observation], *series: Line) -> None:
    for label, value in series:
        axes.plot(times_s, [value(s) for s in samples], label=label, lw=1.2)
    axes.grid(alpha=0.3)


def _twin(
    axes: Axes, times_s: list[float], samples: list[Observation], line: Line, unit: str
) -> Axes:
    """A second y axis on the right, dashed, for a series in other units."""
    twin = axes.twinx()
    label, value = line
    twin.plot(
        times_s, [value(s) for s in samples], color="tab:purple", lw=1.0, ls="--", label=label
    )
    twin.set_ylabel(unit)
    return twin


def _legend(axes: Axes, *more: Axes) -> None:
    """One legend right of the panel (the lines would hide it), twin axis lines included."""
    handles, labels = axes.get_legend_handles_labels()
    for other in more:
        extra_handles, extra_labels = other.get_legend_handles_labels()
        handles, labels = handles + extra_handles, labels + extra_labels
    axes.legend(handles, labels, loc="upper left", bbox_to_anchor=(1.07, 1.0), fontsize="small")


def _mode_panel(axes: Axes, times_s: list[float], samples: list[Observation]) -> None:
    """A logic-analyser view: e-brake and motor enable lanes below the STOP/RC/CAN step line."""
    lanes = {
        "e-brake engaged": (0, [0.8 * s.ebrake_engaged for s in samples], "tab:red"),
        "motors enabled": (1, [0.8 * s.motors_enabled for s in samples], "tab:green"),
    }
    for name, (base, values, colour) in lanes.items():
        tops = [base + value for value in values]
        axes.fill_between(
            times_s, base, tops, step="post", color=colour, alpha=0.5, lw=0, label=name
        )
    axes.step(times_s, [2 + s.mode.value for s in samples], where="post", color="black", lw=1.5)
    modes = sorted(ControlMode, key=lambda mode: mode.value)
    axes.set_yticks([0.4, 1.4, *(2 + mode.value for mode in modes)])
    axes.set_yticklabels(["e-brake", "motors", *(mode.name for mode in modes)])
    axes.set_ylim(-0.2, 2 + max(mode.value for mode in modes) + 0.5)
    axes.set_ylabel("mode")
    axes.grid(alpha=0.3, axis="x")
    _legend(axes)


def _panels(figure: Figure, run: SimRun) -> list[Axes]:
    samples = list(run.record.samples)
    times_s = [s.time_s - run.started_at for s in samples]
    command, drive, brake_steer, motion, mode = figure.subplots(5, 1, sharex=True)
    _lines(
        command,
        times_s,
        samples,
        ("steering", lambda s: s.steering_cmd_norm),
        ("throttle", lambda s: s.throttle_cmd_norm),
        ("brake", lambda s: s.brake_cmd_norm),
    )
    command.set_ylabel("command (norm)")
    _legend(command)
    _lines(
        drive,
        times_s,
        samples,
        ("throttle", lambda s: s.throttle_volts),
        ("regen brake", lambda s: s.regen_volts),
    )
    drive.set_ylabel("DAC output (V)")
    _legend(drive)
    _lines(brake_steer, times_s, samples, ("hydraulic brake", lambda s: s.hydrobrake_duty))
    brake_steer.set_ylabel("PWM duty")
    pulse = _twin(
        brake_steer,
        times_s,
        samples,
        ("steering pulse", lambda s: s.steering_pulse_s * 1000),
        "pulse (ms)",
    )
    _legend(brake_steer, pulse)
    _lines(motion, times_s, samples, ("speed", lambda s: s.speed_mps))
    motion.set_ylabel("speed (m/s)")
    steering = _twin(
        motion,
        times_s,
        samples,
        ("steering (actual)", lambda s: s.steering_actual_norm),
        "steering (norm)",
    )
    _legend(motion, steering)
    _mode_panel(mode, times_s, samples)
    mode.set_xlabel("time (s)")
    return [command, drive, brake_steer, motion, mode]


def _mark_events(panels: list[Axes], run: SimRun) -> None:
    for index, timing in enumerate(run.record.fault_timings):
        at_s = timing.at_s - run.started_at
        for axes in panels:
            axes.axvline(at_s, color="tab:gray", ls=":", lw=1.0)
        # Staggered heights, so that labels of events close in time do not overlap.
        panels[0].annotate(
            timing.label,
            (at_s, 1.0),
            xycoords=("data", "axes fraction"),
            xytext=(2, 2 + 10 * (index % 3)),
            textcoords="offset points",
            fontsize="small",
        )


def write_plot(run: SimRun, path: Path) -> None:
    """Draw the run's record (one sample every 10 ms) into one PNG at `path`."""
    check_plot_path(path)
    if not run.record.samples:
        raise ConfigError("nothing to plot: the run recorded no samples")
    from matplotlib.figure import Figure  # noqa: PLC0415 -- only when drawing (docstring)

    figure = Figure(figsize=SIZE_IN, dpi=DPI, layout="constrained")
    panels = _panels(figure, run)
    _mark_events(panels, run)
    panels[-1].set_xlim(0.0, run.duration_s)
    figure.suptitle(f"bywire sim: {run.scenario.name}: {run.scenario.description}", fontsize=11)
    try:
        figure.savefig(path, dpi=DPI)
    except OSError as error:
        raise ConfigError(f"cannot write {path}: {error.strerror}") from error
