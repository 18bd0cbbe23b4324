"""The dashboard's text: panels and task-table cells from a snapshot (pure, no textual)."""

from __future__ import annotations

from rich.text import Text

from bywire.dashboard.snapshot import DashboardSnapshot
from bywire.sim.summary import TaskRow

TASK_COLUMNS = (
    "task",
    "rate",
    "nominal",
    "runtime",
    "jitter p99",
    "jitter max",
    "overruns",
    "over budget",
)
IDLE_ROW = "idle"
MODE_STYLES = {"STOP": "bold red", "RC": "bold yellow", "CAN": "bold green"}


def _ms(seconds: float | None, digits: int = 0) -> str:
    return "—" if seconds is None else f"{seconds * 1000:.{digits}f} ms"


def _fixed(value: float, spec: str) -> str:
    """Formatted without a negative zero (a brake of -0.00 reads like a fault)."""
    return format(value + 0.0, spec)


def _on(value: bool, yes: str = "on", no: str = "off") -> str:
    return yes if value else no


def mode_panel(snap: DashboardSnapshot, status: str | None = None) -> Text:
    """Mode, latch and error flags (red while any is set)."""
    mode = snap.mode
    text = Text("mode ")
    text.append(mode.mode, style=MODE_STYLES.get(mode.mode, "bold"))
    text.append(f"  {'armed' if mode.armed else 'LATCHED'}")
    text.append(f"  t {snap.elapsed_s:.1f} s\n")
    if mode.latch is not None:
        text.append(f"latched by {mode.latch}: {mode.latch_reason}\n", style="yellow")
    if mode.direction_change_held:
        text.append("direction change held until standstill\n", style="yellow")
    flags = ", ".join(snap.error_flags) or "none"
    text.append(f"error flags: {flags}", style="bold red" if snap.error_flags else "green")
    if snap.watchdog_tripped:
        text.append("\nWATCHDOG TRIPPED", style="bold red")
    if status:
        text.append(f"\n{status}", style="bold")
    return text


def command_panel(snap: DashboardSnapshot) -> Text:
    """The selected movement set-point and where it came from."""
    command = snap.command
    return Text(
        "\n".join(
            [
                f"source   {command.source}",
                f"steering {_fixed(command.steering_norm, '+.2f')}",
                f"throttle {_fixed(command.throttle_norm, '.2f')}",
                f"brake    {_fixed(command.brake_norm, '.2f')}",
                f"gear     {command.gear}",
            ]
        )
    )


def actuator_panel(snap: DashboardSnapshot) -> Text:
    """What the actuators are told."""
    out = snap.actuators
    motors = f"{_on(out.motors_enabled, 'enabled', 'disabled')} {out.direction}"
    return Text(
        "\n".join(
            [
                f"steering pulse {out.steering_pulse_ms:.3f} ms",
                f"throttle {_fixed(out.throttle_volts, '.2f')} V",
                f"regen {_fixed(out.regen_volts, '.2f')} V",
                f"hydrobrake duty {_fixed(out.hydrobrake_duty, '.2f')}",
                f"e-brake {_on(out.ebrake_engaged, 'ENGAGED', 'released')}",
                f"motors {motors}",
                f"lights {', '.join(out.lights_on) or 'off'}",
            ]
        )
    )


def input_panel(snap: DashboardSnapshot) -> Text:
    """Input ages and the readers' counts."""
    inputs = snap.inputs
    rejected = ", ".join(f"{n} {reason}" for reason, n in inputs.can_rejected) or "none"
    return Text(
        "\n".join(
            [
                f"RC age {_ms(inputs.rc_age_s)}  CAN movement age {_ms(inputs.can_movement_age_s)}",
                f"IBUS {inputs.ibus_frames} frames, {inputs.ibus_checksum_errors} checksum errors,"
                f" {inputs.ibus_resyncs} resyncs",
                f"CAN rejected: {rejected}",
                f"reports sent {inputs.reports_sent}",
            ]
        )
    )


def task_cells(row: TaskRow) -> tuple[str, ...]:
    """One task's row, in `TASK_COLUMNS` order (Figure 30 with rates and jitter)."""
    return (
        row.name,
        f"{row.rate_hz:.1f} Hz",
        f"{row.nominal_rate_hz:.0f} Hz",
        f"{row.runtime_share_pct:.2f} %",
        _ms(row.jitter_p99_s, 3),
        _ms(row.jitter_max_s, 3),
        str(row.overruns),
        str(row.budget_exceeded),
    )


def idle_cells(snap: DashboardSnapshot) -> tuple[str, ...]:
    """The rest of the time, as Figure 30's IDLE row."""
    blank = ("",) * (len(TASK_COLUMNS) - 4)
    return (IDLE_ROW, "", "", f"{snap.idle_share_pct:.2f} %", *blank)
