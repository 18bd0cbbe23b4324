"""The transport listens on loopback only: the address parser and the bound socket."""

from __future__ import annotations

import socket

import pytest

from bywire.cli.main import main
from bywire.errors import ConfigError
from bywire.loopback import Endpoint, parse_endpoint
from bywire.netbus.server import SocketcandServer


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("29536", Endpoint("127.0.0.1", 29536)),
        ("localhost:0", Endpoint("127.0.0.1", 0)),
        ("127.0.0.1:5", Endpoint("127.0.0.1", 5)),
        ("[::1]:7", Endpoint("::1", 7)),
        ("::1:7", Endpoint("::1", 7)),
    ],
)
def test_loopback_endpoints_are_accepted(text: str, expected: Endpoint) -> None:
    assert parse_endpoint(text) == expected


@pytest.mark.parametrize(
    "text",
    ["0.0.0.0:29536", "[::]:29536", ":29536", "192.168.1.20:29536", "example.com:1", "10.0.0.1:1"],
)
def test_any_other_host_is_refused(text: str) -> None:
    with pytest.raises(ConfigError, match="loopback only"):
        parse_endpoint(text)


@pytest.mark.parametrize("text", ["port", "1:2:x", "70000"])
def test_a_bad_port_is_refused(text: str) -> None:
    with pytest.raises(ConfigError):
        parse_endpoint(text)


def test_the_server_cannot_be_built_on_another_address() -> None:
    with pytest.raises(ConfigError, match="loopback only"):
        SocketcandServer(Endpoint("0.0.0.0", 0))


def test_the_listening_socket_is_bound_to_127_0_0_1() -> None:
    with SocketcandServer(parse_endpoint("0")) as server:
        host, port = server.address
        assert host == "127.0.0.1"
        assert port > 0


def _has_ipv6_loopback() -> bool:
    try:
        with socket.socket(socket.AF_INET6) as probe:
            probe.bind(("::1", 0))
    except OSError:
        return False
    return True


@pytest.mark.skipif(not _has_ipv6_loopback(), reason="no IPv6 loopback on this machine")
def test_the_listening_socket_can_be_bound_to_ipv6_loopback() -> None:
    with SocketcandServer(parse_endpoint("[::1]:0")) as server:
        assert server.address[0] == "::1"


def test_bywire_sim_refuses_to_serve_on_all_interfaces(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["sim", "--realtime", "--serve", "0.0.0.0:29536", "--duration", "0.1"])
    assert exit_info.value.code == 2
    assert "loopback only" in capsys.readouterr().err


def test_bywire_sim_serves_in_real_time_only(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "--serve", "0", "--duration", "0.1"]) == 2
    assert "--serve needs --realtime" in capsys.readouterr().err
