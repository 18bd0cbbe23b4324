"""Loading: a TOML file or text into a validated RobotConfig, or the packaged simulator default."""

from __future__ import annotations

import tomllib
from collections.abc import Mapping
from importlib import resources
from pathlib import Path

from bywire.config.actuators import (
    drive_section,
    ebrake_section,
    estop_section,
    hydrobrake_section,
    lights_section,
    tasks_section,
)
from bywire.config.consistency import check_consistency
from bywire.config.reader import KeyRead, Problems, Table
from bywire.config.sections import (
    can_section,
    interlocks_section,
    monitors_section,
    rc_section,
    realtime_section,
    sim_section,
    steering_section,
    stop_section,
    supervisor_section,
    telemetry_section,
    timeouts_section,
)
from bywire.config.security import SecuritySection, security_section
from bywire.config.speed_limit import limits_section
from bywire.config.tree import BACKENDS, Backend, RobotConfig
from bywire.config.vehicle import vehicle_section
from bywire.errors import ConfigError
from bywire.security.keys import check_configuration_file, read_key_file
from bywire.textfile import read_text

DEFAULT_SIM_RESOURCE = ("defaults", "sim.toml")


def load_config(path: Path | str) -> RobotConfig:
    """Read and validate one robot's TOML file; ConfigError names the file and what is wrong."""
    text = read_text(Path(path), "configuration file")
    config = parse_config(text, str(path))
    if config.security.enabled:
        check_security_files(Path(path), config.security)
    return config


def check_security_files(path: Path, security: SecuritySection) -> None:
    """StrictModes for authentication: the file that names the key (and could turn it off)
    writable only by its owner, the key private and well formed; ConfigError otherwise."""
    check_configuration_file(path)
    if security.key_file is not None:
        read_key_file(Path(security.key_file))


def parse_config(text: str, origin: str = "<string>") -> RobotConfig:
    """Validate TOML text; every problem found is reported at once, each naming its key."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise ConfigError(f"{origin}: invalid TOML: {_located(error, text)}") from error
    except ValueError as error:  # an integer of more digits than Python converts
        raise ConfigError(f"{origin}: invalid TOML: {error}") from None
    except RecursionError:
        raise ConfigError(f"{origin}: invalid TOML: arrays or tables nested too deep") from None
    problems = Problems(origin)
    config = build_robot(data, problems)
    check_consistency(config, problems)
    problems.check()
    return config


def default_sim_config() -> RobotConfig:
    """The simulator's configuration, shipped in the package as bywire/defaults/sim.toml."""
    resource = resources.files("bywire")
    for part in DEFAULT_SIM_RESOURCE:
        resource = resource.joinpath(part)
    return parse_config(resource.read_text(encoding="utf-8"), "bywire/defaults/sim.toml")


def _located(error: tomllib.TOMLDecodeError, text: str) -> str:
    """tomllib names the line of every error but the last one; name that one's line too."""
    last_line = f"end of document, line {len(text.splitlines()) or 1}"
    return str(error).replace("end of document", last_line)


def read_schema(text: str, origin: str = "<string>") -> tuple[KeyRead, ...]:
    """Every key the loader reads, in reading order, with its allowed values and the value this
    text gives it (its default when absent): the loader's own account of its legal space. The
    text must load (ConfigError otherwise)."""
    parse_config(text, origin)
    schema: list[KeyRead] = []
    build_robot(tomllib.loads(text), Problems(origin), schema)
    return tuple(schema)


def build_robot(
    data: Mapping[str, object], problems: Problems, schema: list[KeyRead] | None = None
) -> RobotConfig:
    """The whole tree from a parsed TOML document; problems are recorded, not raised (and, with
    `schema`, every key read is recorded there: `read_schema`)."""
    root, default = Table(data, "", problems, schema), RobotConfig()
    backend_name = root.text("backend", default.backend, BACKENDS)
    backend: Backend = "linux" if backend_name == "linux" else "sim"
    chip = root.text("gpio_chip", default.gpio_chip)
    config = RobotConfig(
        name=root.text("name", default.name),
        backend=backend,
        gpio_chip=chip,
        can=can_section(root.table("can")),
        rc=rc_section(root.table("rc")),
        steering=steering_section(root.table("steering")),
        drive=drive_section(root.table("drive"), chip),
        hydrobrake=hydrobrake_section(root.table("hydrobrake")),
        ebrake=ebrake_section(root.table("ebrake"), chip),
        lights=lights_section(root.table("lights"), chip),
        estop=estop_section(root.table("estop"), chip),
        timeouts=timeouts_section(root.table("timeouts")),
        stop=stop_section(root.table("stop")),
        interlocks=interlocks_section(root.table("interlocks")),
        monitors=monitors_section(root.table("monitors")),
        supervisor=supervisor_section(root.table("supervisor")),
        tasks=tasks_section(root.table("tasks"), chip),
        realtime=realtime_section(root.table("realtime")),
        telemetry=telemetry_section(root.table("telemetry")),
        sim=sim_section(root.table("sim")),
        security=security_section(root.table("security"), backend),
        vehicle=vehicle_section(root.table("vehicle")),
        limits=limits_section(root.table("limits")),
    )
    root.close()
    return config
