"""The `[limits]` table: the top speed the controller enforces (`control.governor`), raised step
by step as testing goes on.

A file that does not set it gets the simulator's 2.0 m/s, not "no limit": a robot file written
before the limit existed, or one that forgot it, drives slowly rather than at whatever its drive
gives (issue 44: the operator walks behind). No limit is a deliberate statement,
`max_speed_mps = "none"` (as an E-stop line's "none"), which `config check` repeats."""

from __future__ import annotations

from dataclasses import dataclass, field

from bywire.config.reader import Interval, Table, toml_type
from bywire.config.vehicle import VehicleSection
from bywire.control.governor import (
    GovernorConfig,
    band_mps,
    ceiling_throttle,
    margin_mps,
)

MAX_SPEED_MPS = Interval(0.1, 30.0, "m/s")
NO_LIMIT = "none"
WRITTEN_NONE = "written_none"
"""A field's metadata key: how the file writes the field's None (`config.render`)."""
DEFAULT_MAX_SPEED_MPS = 2.0


@dataclass(frozen=True, slots=True)
class LimitsSection:
    """`max_speed_mps`: the speed limit, in m/s, both directions (None: none, the file's "none")."""

    max_speed_mps: float | None = field(
        default=DEFAULT_MAX_SPEED_MPS, metadata={WRITTEN_NONE: NO_LIMIT}
    )


def limits_section(table: Table) -> LimitsSection:
    value = table.get("max_speed_mps")
    if value == NO_LIMIT:
        section = LimitsSection(None)
    elif isinstance(value, str):
        allowed = f'a number in {MAX_SPEED_MPS} or "{NO_LIMIT}"'
        table.refuse("max_speed_mps", value, f"expected {allowed}, got {toml_type(value)}")
        section = LimitsSection()
    else:
        section = LimitsSection(table.number("max_speed_mps", DEFAULT_MAX_SPEED_MPS, MAX_SPEED_MPS))
    table.close()
    return section


def governor_config(limits: LimitsSection, vehicle: VehicleSection) -> GovernorConfig:
    """The governor's configuration: the limit, and the throttle ceiling derived from it and the
    vehicle's flat-ground calibration."""
    limit = limits.max_speed_mps
    if limit is None:
        return GovernorConfig()
    ceiling = ceiling_throttle(limit, vehicle.flat_speeds_mps, vehicle.flat_throttles)
    return GovernorConfig(limit, ceiling)


def enforcement(limits: LimitsSection, vehicle: VehicleSection) -> list[str]:
    """How the limit is enforced, in words (`bywire config check`)."""
    limit = limits.max_speed_mps
    if limit is None:
        return [
            'no speed limit: the file says max_speed_mps = "none"; the controller limits nothing'
        ]
    ceiling = governor_config(limits, vehicle).ceiling_throttle_norm
    band, margin = band_mps(limit), margin_mps(limit)
    return [
        f"speed limit {limit:g} m/s ({limit * 3.6:.1f} km/h), both directions, RC and CAN mode",
        f"with a trusted wheel speed: a governor; the throttle is reduced from"
        f" {limit - band:.2f} m/s to none at {limit:g} m/s, the brake begins above"
        f" {limit + margin:.2f} m/s and is full at {limit + 2 * margin:.2f} m/s",
        f"without one: a throttle ceiling of {ceiling:.3f}, derived from the limit and the"
        " vehicle's calibration ([vehicle] flat_speeds_mps / flat_throttles); not a governor:"
        " downhill the robot can pass the limit",
    ]
