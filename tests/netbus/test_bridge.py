"""The simulated bus served over socketcand, on virtual time: the poll runs as the clock moves."""

from __future__ import annotations

import time

import can

from bywire.can_frame import CanFrame
from bywire.hal.simulated.can_bus import SimCanBus
from bywire.hal.simulated.clock import VirtualClock
from bywire.loopback import Endpoint
from bywire.netbus.bridge import serve_bus
from tests.netbus.test_server import TIMEOUT_S, receive, wait_for


def test_bus_frames_reach_a_client_and_its_frames_reach_the_bus() -> None:
    clock = VirtualClock()
    bus = SimCanBus(clock)
    robot = bus.attach("robot")
    with serve_bus(bus, Endpoint("127.0.0.1", 0), start_s=0.0) as bridge:
        host, port = bridge.server.address
        client = can.Bus(interface="socketcand", host=host, port=port, channel="can0")
        try:
            wait_for(lambda: bridge.server.client_count == 1, "the client")
            before_s = time.time()
            robot.send(CanFrame(0x200, b"\x11\x04"))
            clock.advance(0.01)
            (message,) = receive(client, 1)
            assert (message.arbitration_id, bytes(message.data)) == (0x200, b"\x11\x04")
            assert abs(message.timestamp - before_s) < 5.0  # wall-clock stamps, as the log has

            client.send(can.Message(arbitration_id=0x101, data=b"\x07", is_extended_id=False))
            deadline = time.monotonic() + TIMEOUT_S
            while not any(f.arbitration_id == 0x101 for f in bus.log):
                assert time.monotonic() < deadline, "the client's frame never reached the bus"
                clock.advance(0.01)
                time.sleep(0.001)
        finally:
            client.shutdown()
    (sent,) = [f for f in bus.log if f.arbitration_id == 0x101]
    assert (sent.data, sent.sender) == (b"\x07", "remote1")
    assert [f.data for f in robot.receive() if f.arbitration_id == 0x101] == [b"\x07"]


def test_frames_the_bus_cannot_carry_are_counted_not_fatal() -> None:
    clock = VirtualClock()
    bus = SimCanBus(clock)
    with serve_bus(bus, Endpoint("127.0.0.1", 0), start_s=0.0) as bridge:
        host, port = bridge.server.address
        client = can.Bus(interface="socketcand", host=host, port=port, channel="can0")
        try:
            client.send(can.Message(arbitration_id=0x1ABCDE0, data=b"", is_extended_id=True))
            deadline = time.monotonic() + TIMEOUT_S
            while bridge.refused == 0:
                assert time.monotonic() < deadline, "the extended frame was never refused"
                clock.advance(0.01)
                time.sleep(0.001)
        finally:
            client.shutdown()
    assert all(f.arbitration_id != 0x1ABCDE0 for f in bus.log)
