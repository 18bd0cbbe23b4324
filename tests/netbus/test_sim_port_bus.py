"""A simulated CAN node behind python-can's bus interface: frames both ways, full mailboxes."""

from __future__ import annotations

import can
import pytest

from bywire.can_frame import CanFrame
from bywire.hal.simulated.can_bus import SimCanBus
from bywire.hal.simulated.clock import VirtualClock
from tests.netbus.sim_port_bus import SimPortBus


def make() -> tuple[VirtualClock, SimCanBus, SimPortBus]:
    clock = VirtualClock(start_s=5.0)
    sim_bus = SimCanBus(clock)
    return clock, sim_bus, SimPortBus(sim_bus.attach("teleop"))


def test_sent_messages_reach_the_other_nodes() -> None:
    clock, sim_bus, bus = make()
    robot = sim_bus.attach("robot")
    bus.send(can.Message(arbitration_id=0x101, data=b"\x01\x02", is_extended_id=False))
    clock.advance(0.01)
    [frame] = robot.receive()
    assert (frame.arbitration_id, frame.data) == (0x101, b"\x01\x02")


def test_received_frames_come_out_in_order_with_simulation_timestamps() -> None:
    clock, sim_bus, bus = make()
    robot = sim_bus.attach("robot")
    assert bus.recv(timeout=0.0) is None
    robot.send(CanFrame(0x201, b"\xaa"))
    robot.send(CanFrame(0x202, b"\xbb"))
    clock.advance(0.01)
    first, second = bus.recv(timeout=0.0), bus.recv(timeout=0.0)
    assert first is not None
    assert second is not None
    assert (first.arbitration_id, bytes(first.data)) == (0x201, b"\xaa")
    assert second.arbitration_id == 0x202
    assert 5.0 < first.timestamp < second.timestamp < 5.01
    assert bus.recv(timeout=0.0) is None


def test_full_mailboxes_raise_a_python_can_error() -> None:
    _, _, bus = make()
    message = can.Message(arbitration_id=0x101, data=b"", is_extended_id=False)
    for _ in range(3):  # bxCAN's three mailboxes; the clock does not run, nothing leaves
        bus.send(message)
    with pytest.raises(can.CanOperationError):
        bus.send(message)


def test_shutdown_hands_deliveries_back_to_the_node() -> None:
    clock = VirtualClock()
    sim_bus = SimCanBus(clock)
    port = sim_bus.attach("teleop")
    robot = sim_bus.attach("robot")
    SimPortBus(port).shutdown()
    robot.send(CanFrame(0x201, b"\xaa"))
    clock.advance(0.01)
    assert [frame.arbitration_id for frame in port.receive()] == [0x201]
