"""Where bywire's servers may listen: loopback only, parsed from ``[HOST:]PORT``.

The simulated bus's socketcand server (`bywire.netbus`) and the telemetry feed's Foxglove server
(`bywire.telemetry`) have no authentication: anyone who can reach the bus server can put frames on
the robot's bus. So `Endpoint` binds to the loopback interface only and refuses every other
address, 0.0.0.0 included; `ListenAddress` is the exception a robot configuration may ask for
(`allow_remote`). A module of its own, as errors.py, because the servers and the configuration
all read it.
"""

from __future__ import annotations

from dataclasses import dataclass

from bywire.errors import ConfigError

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 29536  # socketcand's customary port
LOOPBACK_HOSTS = {"127.0.0.1": "127.0.0.1", "localhost": "127.0.0.1", "::1": "::1"}


@dataclass(frozen=True, slots=True)
class Endpoint:
    """A loopback address and TCP port (0: let the system choose a free port)."""

    host: str
    port: int

    def __post_init__(self) -> None:
        loopback_host(self.host)
        if not 0 <= self.port <= 65535:
            raise ConfigError(f"port must be 0..65535, got {self.port}")

    def __str__(self) -> str:
        return f"[{self.host}]:{self.port}" if ":" in self.host else f"{self.host}:{self.port}"


def loopback_host(host: str) -> str:
    """The loopback address for ``host``; ConfigError for any other host (0.0.0.0 included)."""
    address = LOOPBACK_HOSTS.get(host.strip("[]").lower())
    if address is None:
        raise ConfigError(
            f"the bus transport listens on loopback only (127.0.0.1, ::1 or localhost),"
            f" not {host!r}: it has no authentication, so it must not be reachable from"
            " the network (use an SSH tunnel for remote access)"
        )
    return address


@dataclass(frozen=True, slots=True)
class ListenAddress:
    """Where a server listens when the configuration allows more than loopback (any host)."""

    host: str
    port: int

    def __str__(self) -> str:
        return f"[{self.host}]:{self.port}" if ":" in self.host else f"{self.host}:{self.port}"


def parse_listen_address(text: str, *, allow_remote: bool) -> Endpoint | ListenAddress:
    """``[HOST:]PORT`` as `parse_endpoint` reads it; with `allow_remote` any host is taken (an
    empty one, or 0.0.0.0, listens on every interface), else loopback only (ConfigError)."""
    if not allow_remote:
        return parse_endpoint(text)
    host, separator, port_text = text.rpartition(":")
    try:
        port = int(port_text)
    except ValueError:
        raise ConfigError(f"expected [HOST:]PORT, got {text!r}") from None
    if not 0 <= port <= 65535:
        raise ConfigError(f"port must be 0..65535, got {port}")
    host = host.strip("[]") if separator else DEFAULT_HOST
    if host.lower() in LOOPBACK_HOSTS:
        return Endpoint(loopback_host(host), port)
    return ListenAddress(host or "0.0.0.0", port)  # every interface: the configuration asked


def parse_endpoint(text: str) -> Endpoint:
    """``PORT``, ``HOST:PORT`` or ``[::1]:PORT`` -> Endpoint; the host defaults to 127.0.0.1."""
    host, separator, port_text = text.rpartition(":")
    try:
        port = int(port_text)
    except ValueError:
        raise ConfigError(f"expected [HOST:]PORT, got {text!r}") from None
    # An empty host means "every interface" to bind(): refused like 0.0.0.0.
    return Endpoint(loopback_host(host) if separator else DEFAULT_HOST, port)
