"""One TOML file per robot, validated at load into a frozen RobotConfig (R-CONFIG).

Every problem is a ConfigError naming the file, the dotted key, the bad value and what is
allowed; unknown keys are refused with the nearest known key suggested. Missing keys take the
simulator's defaults, which also ship as `bywire/defaults/sim.toml`.
"""

from bywire.config.loader import default_sim_config, load_config, parse_config
from bywire.config.render import as_dict, describe
from bywire.config.tree import (
    OUTPUT_LINE_KEYS,
    Backend,
    CanSection,
    DacOutput,
    DriveSection,
    EbrakeSection,
    GpioLine,
    HydrobrakeSection,
    LightsSection,
    PwmOutput,
    RcSection,
    RealtimeSection,
    RobotConfig,
    SimSection,
    SteeringSection,
    StopSection,
    TasksSection,
    TelemetrySection,
    TimeoutsSection,
    output_lines,
)
from bywire.config.vehicle import VehicleSection

__all__ = [
    "OUTPUT_LINE_KEYS",
    "Backend",
    "CanSection",
    "DacOutput",
    "DriveSection",
    "EbrakeSection",
    "GpioLine",
    "HydrobrakeSection",
    "LightsSection",
    "PwmOutput",
    "RcSection",
    "RealtimeSection",
    "RobotConfig",
    "SimSection",
    "SteeringSection",
    "StopSection",
    "TasksSection",
    "TelemetrySection",
    "TimeoutsSection",
    "VehicleSection",
    "as_dict",
    "default_sim_config",
    "describe",
    "load_config",
    "output_lines",
    "parse_config",
]
