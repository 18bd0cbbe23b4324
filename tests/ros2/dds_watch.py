"""Watching network interfaces for DDS traffic while the ROS 2 tier runs: RTPS datagrams,
multicast and IGMP, captured with scapy (root only). No rclpy needed, so the main suite tests the
classifier on packets it builds (nothing is sent)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

RTPS_MAGIC = b"RTPS"
IFF_UP = 0x1
IGMP = 2


def dds_packet(packet: Any) -> bool:
    """An RTPS datagram, a multicast datagram (IPv4 or IPv6), or an IGMP membership message."""
    from scapy.layers.inet import IP, UDP  # noqa: PLC0415 -- loaded with the sniffer
    from scapy.layers.inet6 import IPv6  # noqa: PLC0415

    if IP in packet and (packet[IP].proto == IGMP or packet[IP].dst.startswith("239.")):
        return True
    if IPv6 in packet and packet[IPv6].dst.lower().startswith("ff"):
        return True
    return UDP in packet and bytes(packet[UDP].payload)[:4] == RTPS_MAGIC


class Sniffer:
    """Captures DDS traffic on the given interfaces while the tests run (needs root)."""

    def __init__(self, interfaces: list[str]) -> None:
        # The layers first: a packet is dissected as it arrives, with the layers loaded then.
        import scapy.layers.inet  # noqa: PLC0415
        import scapy.layers.inet6  # noqa: F401, PLC0415
        from scapy.sendrecv import AsyncSniffer  # noqa: PLC0415

        self.interfaces = interfaces
        self._sniffer = AsyncSniffer(iface=interfaces, lfilter=dds_packet, store=True)

    def start(self) -> None:
        self._sniffer.start()

    def stop(self) -> list[Any]:
        self._sniffer.stop()
        return list(self._sniffer.results or [])


def network_interfaces() -> tuple[list[str], list[str]]:
    """(loopback, every other interface that is up) of this machine: a down one carries nothing
    (and cannot be watched)."""
    up = sorted(
        path.name
        for path in Path("/sys/class/net").iterdir()
        if int((path / "flags").read_text(), 16) & IFF_UP
    )
    return [name for name in up if name == "lo"], [name for name in up if name != "lo"]
