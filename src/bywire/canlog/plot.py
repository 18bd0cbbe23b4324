"""A PNG of a CAN log: any DBC's signals, one panel per unit; or Albert's own view (R-PLOT).

For any DBC, `draw_signals` draws the chosen signals (`choose_signals`: `--signal` globs, or a
default of the signals that change, counters and checksums left out), one panel per unit.

For albert.dbc, `draw_log` draws what the bus shows of a run, like `bywire sim --plot`: the
higher-level computer's movement set-points, the steering the controller commanded and measured,
the wheel speeds, the lights and the number of error flags up (the ErrorReport's 1-bit flag
signals, the names of those seen in the legend), and the control mode with the e-brake and the
STOP latch.
"""

from __future__ import annotations

import fnmatch
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from difflib import get_close_matches
from pathlib import Path

from cantools.database.can import Database
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from bywire.canlog.read import DecodedLog, Signal
from bywire.error_flags import ErrorFlag
from bywire.errors import ConfigError
from bywire.model import ControlMode
from bywire.plot_page import DPI, SIZE_IN

LIGHTS = ("brake", "reverse", "turn_left", "turn_right", "hazard", "low_beam", "error_led")
LANE_HEIGHT = 0.8
# Signals Albert's view needs: a log with all of them is drawn that way unless --signal is given.
ALBERT_SIGNALS = (
    "MovementCommand.steering_norm",
    "SteeringReport.commanded_norm",
    "WheelSpeedReport.left_mps",
    "ModeReport.control_mode",
)
MAX_DEFAULT_SIGNALS = 12
MAX_PANELS = 6
MAX_LINES_PER_PANEL = 6
PANEL_HEIGHT_IN = 2.4
SPARSE_SAMPLES = 50
MAX_LEGEND_ENTRIES = 12
# Bookkeeping, not data: rolling counters, checksums and CRCs stay out of the default choice.
_BOOKKEEPING = re.compile(r"count(er)?\b|_cnt|cnt$|checksum|chksum|crc|alive", re.IGNORECASE)


@dataclass(frozen=True)
class Choice:
    """The signals to draw, each with its unit ("" for none), and how many the log offered."""

    signals: tuple[tuple[str, str], ...]
    offered: int
    defaulted: bool


def is_albert_log(log: DecodedLog) -> bool:
    """Whether the log holds Albert's own messages (then `draw_log` is the default view)."""
    return all(name in log.signals for name in ALBERT_SIGNALS)


def signal_units(database: Database) -> dict[str, str]:
    """``Message.signal`` -> unit ("" when the DBC gives none), for every signal of the DBC."""
    return {
        f"{message.name}.{signal.name}": signal.unit or ""
        for message in database.messages
        for signal in message.signals
    }


def choose_signals(log: DecodedLog, database: Database, patterns: Sequence[str]) -> Choice:
    """The signals named by `patterns` (globs on ``Message.signal``; a pattern without a dot
    matches the signal name of any message), or a default when there are none.

    ConfigError when a pattern matches no signal of the DBC, or no chosen signal is in the log.
    """
    units = signal_units(database)
    if not patterns:
        return _default_choice(log, units)
    chosen: list[str] = []
    for pattern in patterns:
        full = pattern if "." in pattern else f"*.{pattern}"
        matches = [name for name in units if fnmatch.fnmatchcase(name, full)]
        if not matches:
            close = get_close_matches(pattern, list(units), n=3, cutoff=0.5)
            hint = f"; did you mean {', '.join(close)}?" if close else ""
            raise ConfigError(
                f"--signal {pattern!r} matches no signal of the DBC (give MESSAGE.SIGNAL, globs"
                f" allowed, e.g. '{next(iter(units), 'Message.signal')}'){hint}"
            )
        chosen += [name for name in matches if name not in chosen]
    present = [name for name in chosen if log.signal(name).values]
    if not present:
        raise ConfigError(
            f"none of the {len(chosen)} signals chosen with --signal ({', '.join(chosen[:3])}"
            f"{', ...' if len(chosen) > 3 else ''}) is in the log"
        )
    return Choice(tuple((name, units.get(name, "")) for name in present), len(log.signals), False)


def _default_choice(log: DecodedLog, units: dict[str, str]) -> Choice:
    """Up to 12 signals, those that change and those with units first, in at most 6 unit panels
    of at most 6 lines (a multiplexed signal may have one sample; it is drawn as a dot)."""
    order = {name: index for index, name in enumerate(units)}
    candidates = [name for name in log.signals if not _BOOKKEEPING.search(name.partition(".")[2])]
    varies = {name: len(set(log.signal(name).values)) > 1 for name in candidates}
    candidates.sort(
        key=lambda name: (not varies[name], not units.get(name), order.get(name, len(order)))
    )
    panels: dict[str, int] = {}
    chosen: list[tuple[str, str]] = []
    for name in candidates:
        unit = units.get(name, "")
        if unit not in panels and len(panels) == MAX_PANELS:
            continue
        if panels.get(unit, 0) == MAX_LINES_PER_PANEL:
            continue
        panels[unit] = panels.get(unit, 0) + 1
        chosen.append((name, unit))
        if len(chosen) == MAX_DEFAULT_SIGNALS:
            break
    if not chosen:
        raise ConfigError(
            f"nothing to plot: the log's {len(log.signals)} decoded signals are all counters or"
            " checksums (name some with --signal MESSAGE.SIGNAL)"
        )
    return Choice(tuple(chosen), len(log.signals), True)


def draw_signals(log: DecodedLog, choice: Choice, title: str) -> Figure:
    """One panel per unit, one step line per signal (held between frames), shared time axis."""
    by_unit: dict[str, list[str]] = {}
    for name, unit in choice.signals:
        by_unit.setdefault(unit, []).append(name)
    height = max(4.0, PANEL_HEIGHT_IN * len(by_unit) + 1.2)
    figure = Figure(figsize=(SIZE_IN[0], height), dpi=DPI, layout="constrained")
    panels = figure.subplots(len(by_unit), 1, sharex=True, squeeze=False)[:, 0]
    for axes, (unit, names) in zip(panels, by_unit.items(), strict=True):
        for name in names:
            signal = log.signal(name)
            # a few samples get dots: a single sample's step line has no length
            marker = "o" if len(signal.values) < SPARSE_SAMPLES else None
            axes.step(
                signal.times_s, signal.values, where="post", label=name, lw=1.2, marker=marker,
                markersize=3,
            )  # fmt: skip
        axes.set_ylabel(unit or "(no unit)")
        axes.grid(alpha=0.3)
        if len(names) <= MAX_LEGEND_ENTRIES:
            _legend(axes)
        else:  # a legend of dozens of names would push the panel off the figure
            axes.set_title(f"{len(names)} signals: {names[0]} ... {names[-1]}", fontsize="small")
    panels[-1].set_xlabel("time (s)" if log.timed else "frame number (the log has no times)")
    panels[-1].set_xlim(0.0, max(log.duration_s, 1e-3))
    figure.suptitle(title, fontsize=11)
    return figure


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


def error_flags_up(log: DecodedLog) -> Signal:
    """How many error flags each ErrorReport had up, from its per-flag 1-bit signals."""
    lanes = [log.signal(f"ErrorReport.{flag.name}") for flag in ErrorFlag]
    present = [lane for lane in lanes if lane.values]
    if not present:
        return Signal((), ())
    rows = zip(*(lane.values for lane in present), strict=True)  # one frame: every flag
    return Signal(present[0].times_s, tuple(sum(bool(value) for value in row) for row in rows))


def error_flags_seen(log: DecodedLog) -> list[str]:
    """The flags up in any ErrorReport of the log, lowest bit first."""
    return [
        str(flag.name) for flag in ErrorFlag if any(log.signal(f"ErrorReport.{flag.name}").values)
    ]


def _lights_panel(axes: Axes, log: DecodedLog) -> Axes:
    heights = _lanes(axes, {name: log.signal(f"LightsReport.{name}") for name in LIGHTS})
    axes.set_yticks(heights, [name.replace("_", " ") for name in LIGHTS])
    axes.set_ylim(-0.2, len(LIGHTS))
    axes.grid(alpha=0.3, axis="x")
    flags = error_flags_up(log)
    seen = error_flags_seen(log)
    label = "error flags" + (f" ({', '.join(seen)})" if seen else "")
    twin = axes.twinx()
    twin.step(flags.times_s, flags.values, where="post", color="tab:purple", ls="--", label=label)
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
    for side in ("left", "right"):  # a gap where the robot measured no speed (not 0 m/s)
        shown = _where_valid(log, f"{wheels}{side}_mps", wheels + "measured_valid")
        speed.step(shown.times_s, shown.values, where="post", label=side, lw=1.2)
    speed.set_ylabel("speed (m/s)")
    speed.grid(alpha=0.3)
    _legend(speed)
    _legend(lights, _lights_panel(lights, log))
    _mode_panel(mode, log)
    mode.set_xlabel("time (s)")
    mode.set_xlim(0.0, max(log.duration_s, 1e-3))
    figure.suptitle(title, fontsize=11)
    return figure


def check_png_path(path: Path, *, force: bool = True) -> None:
    """ConfigError unless `path` is a .png in an existing folder, new unless `force`."""
    if path.suffix.lower() != ".png":
        raise ConfigError(f"cannot write a plot as {path.name!r}: the suffix must be .png")
    if not path.parent.is_dir():
        raise ConfigError(f"cannot write {path}: folder {path.parent} does not exist")
    if path.exists() and not force:
        raise ConfigError(
            f"{path} exists: add --force to overwrite it, or choose another file with --out"
        )


def write_log_plot(log: DecodedLog, path: Path, title: str, choice: Choice | None = None) -> None:
    """Draw `log` into one PNG at `path`: the chosen signals, or Albert's view when `choice` is
    None. ConfigError when it cannot be written."""
    check_png_path(path)
    figure = draw_log(log, title) if choice is None else draw_signals(log, choice, title)
    try:
        figure.savefig(path, dpi=DPI)
    except OSError as error:
        raise ConfigError(f"cannot write {path}: {error.strerror}") from error
