"""The ROS 2 tier's watch for DDS traffic classifies packets as it must: RTPS, multicast and
IGMP are DDS traffic, the rest (a package download, a DNS lookup) is not. Packets are built, never
sent."""

from __future__ import annotations

from scapy.layers.inet import IP, TCP, UDP
from scapy.layers.inet6 import IPv6
from scapy.layers.l2 import Ether
from scapy.packet import Raw

from tests.ros2.dds_watch import RTPS_MAGIC, dds_packet


def test_rtps_multicast_and_igmp_are_dds_traffic() -> None:
    rtps = Ether() / IP(dst="192.0.2.9") / UDP(dport=7410) / Raw(RTPS_MAGIC + b"\x02\x04")
    multicast = Ether() / IP(dst="239.255.0.1") / UDP(dport=7400) / Raw(b"x")
    igmp = Ether() / IP(dst="224.0.0.22", proto=2) / Raw(b"\x22\x00")
    ipv6 = Ether() / IPv6(dst="ff02::1") / UDP(dport=7400) / Raw(b"x")
    for packet in (rtps, multicast, igmp, ipv6):
        assert dds_packet(Ether(bytes(packet))), packet.summary()  # as captured: from bytes


def test_other_traffic_is_not() -> None:
    https = Ether() / IP(dst="203.0.113.80") / TCP(dport=443) / Raw(b"\x16\x03\x01")
    dns = Ether() / IP(dst="10.255.255.53") / UDP(dport=53) / Raw(b"\x12\x34")
    for packet in (https, dns):
        assert not dds_packet(Ether(bytes(packet))), packet.summary()
