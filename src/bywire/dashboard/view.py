"""The dashboard's text: panels and task-table cells from a snapshot (pure, no textual).

Every panel is four lines of at most `PANEL_WIDTH` characters, so that two panels side by side,
the task table, the header and the footer fit an 80×24 terminal.
"""

from __future__ import annotations

from rich.text import Text

from bywire.dashboard.snapshot import DashboardSnapshot, TaskView

PANEL_WIDTH = 36  # (80 columns / 2) less each panel's border and padding
TASK_COLUMNS = ("task", "rate", "nominal", "runtime", "jitter max", "overruns", "over budget")
IDLE_ROW = "idle"
MODE_STYLES = {"STOP": "bold red", "RC": "bold yellow", "CAN": "bold green"}


def _ms(seconds: float | None) -> str:
    return "—" if seconds is None else f"{seconds * 1000:.0f} ms"


def _fixed(value: float, spec: str) -> str:
    """Formatted without a negative zero (a brake of -0.00 reads like a fault)."""
    return format(value + 0.0, spec)


def _fit(line: str) -> str:
    return line if len(line) <= PANEL_WIDTH else line[: PANEL_WIDTH - 1] + "…"


def mode_panel(snap: DashboardSnapshot) -> Text:
    """Mode, arming, speed, the latch and the error flags (red while any is set)."""
    text = Text("mode ")
    text.append(snap.mode, style=MODE_STYLES.get(snap.mode, "bold"))
    text.append(f"  {'armed' if snap.armed else 'LATCHED'}  t {snap.elapsed_s:.1f} s\n")
    speed = "—" if snap.speed_mps is None else f"{snap.speed_mps:.2f} m/s"
    text.append(_fit(f"speed {speed}"), style="bold")
    text.append(_fit(f"  {speed_limit_text(snap)}") + "\n", style=_limit_style(snap))
    latch = ", ".join(snap.latched) or "none"
    text.append(_fit(f"latched: {latch}") + "\n", style="yellow" if snap.latched else "")
    count = len(snap.error_flags) + snap.watchdog_tripped
    summary = "none" if not count else f"{count} set (below)"
    text.append(f"flags: {summary}", style="bold red" if count else "green")
    return text


def speed_limit_text(snap: DashboardSnapshot) -> str:
    """The speed limit and whether it acts (docs/SAFETY.md row 67)."""
    if snap.speed_limit_mps is None:
        return "no limit"
    acting = ", LIMITING" if snap.speed_limited else ""
    return f"limit {snap.speed_limit_mps:g}{acting}"


def _limit_style(snap: DashboardSnapshot) -> str:
    return "bold yellow" if snap.speed_limited else ""


def flags_line(snap: DashboardSnapshot, verdict: str | None = None) -> Text:
    """Every error flag by name, in full, across the screen (it wraps rather than cut a name):
    the mode panel has room for how many, not which. Then the verdict of the scenario the view
    started, once its run has ended."""
    names = [*(["WATCHDOG"] if snap.watchdog_tripped else []), *snap.error_flags]
    if not names:
        text = Text("error flags: none", style="green")
    else:
        text = Text(f"error flags: {', '.join(names)}", style="bold red")
    if verdict is not None:
        style = "bold green" if verdict.startswith("PASSED") else "bold red"
        text.append("  ·  scenario ")
        text.append(verdict, style=style if verdict[:6] in ("PASSED", "FAILED") else "yellow")
    return text


def command_panel(snap: DashboardSnapshot) -> Text:
    """The selected movement set-point and where it came from."""
    command = snap.command
    lines = [
        f"source {command.source}",
        f"steering {_fixed(command.steering_norm, '+.2f')}   gear {command.gear}",
        f"throttle {_fixed(command.throttle_norm, '.2f')}"
        f"   brake {_fixed(command.brake_norm, '.2f')}",
        "direction change held (standstill)" if snap.direction_change_held else "",
    ]
    return Text("\n".join(_fit(line) for line in lines))


def actuator_panel(snap: DashboardSnapshot) -> Text:
    """What the actuators are told (and the DAC's acknowledged volts)."""
    out = snap.actuators
    dac = "" if out.dac_throttle_volts is None else f" (DAC {out.dac_throttle_volts:.2f})"
    motors = f"motors {'enabled' if out.motors_enabled else 'disabled'} {out.direction}"
    lines = [
        f"throttle {_fixed(out.throttle_volts, '.2f')} V{dac}",
        f"{motors}, regen {_fixed(out.regen_volts, '.2f')} V",
        f"e-brake {'ENGAGED' if out.ebrake_engaged else 'released'}"
        f", hydro {_fixed(out.hydrobrake_duty, '.2f')}",
        f"servo {out.steering_pulse_ms:.3f} ms, lights {','.join(out.lights_on) or 'off'}",
    ]
    return Text("\n".join(_fit(line) for line in lines))


def input_panel(snap: DashboardSnapshot) -> Text:
    """Input ages and counts, reports sent, and what the feed dropped."""
    inputs = snap.inputs
    lines = [
        f"RC age {_ms(inputs.rc_age_s)}, {inputs.rc_frames} frames",
        f"CAN age {_ms(inputs.can_movement_age_s)}, {inputs.can_control_frames} control",
        f"reports sent {inputs.reports_sent}",
        f"feed dropped {inputs.telemetry_dropped}",
    ]
    return Text("\n".join(_fit(line) for line in lines))


def task_cells(row: TaskView) -> tuple[str, ...]:
    """One task's row, in `TASK_COLUMNS` order."""
    return (
        row.name,
        f"{row.rate_hz:.1f} Hz",
        f"{row.nominal_rate_hz:.0f} Hz",
        f"{row.runtime_share_pct:.2f} %",
        f"{row.jitter_max_ms:.3f} ms",
        str(row.overruns),
        str(row.budget_exceeded),
    )


def idle_cells(snap: DashboardSnapshot) -> tuple[str, ...]:
    """The rest of the time, as Figure 30's IDLE row."""
    blank = ("",) * (len(TASK_COLUMNS) - 4)
    return (IDLE_ROW, "", "", f"{snap.idle_share_pct:.2f} %", *blank)
