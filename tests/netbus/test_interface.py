"""The simulated bus on a python-can interface: frames out, frames in, none echoed back."""

from __future__ import annotations

import time
import uuid

import can

from bywire.can_frame import CanFrame
from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.world import SimWorld
from bywire.netbus.interface import NODE, on_interface

LIMIT_S = 5.0


def _channel() -> str:
    return f"bywire-interface-{uuid.uuid4().hex[:8]}"


def test_the_buss_frames_go_out_and_the_interfaces_come_in() -> None:
    clock = VirtualClock()
    world = SimWorld.create(clock)
    robot = world.bus.attach("robot", accept_ids=(0x101,))
    channel = _channel()
    peer = can.Bus(interface="virtual", channel=channel)
    try:
        with on_interface(world.bus, can.Bus(interface="virtual", channel=channel)) as bridge:
            robot.send(CanFrame(0x200, b"\x01\x02"))
            clock.advance(0.01)
            out = peer.recv(LIMIT_S)
            assert out is not None
            assert (out.arbitration_id, bytes(out.data)) == (0x200, b"\x01\x02")
            peer.send(can.Message(arbitration_id=0x101, data=bytes(8), is_extended_id=False))
            peer.send(can.Message(arbitration_id=0x1ABCDE, data=b"", is_extended_id=True))
            received: list[CanFrame] = []
            deadline_s = time.monotonic() + LIMIT_S
            while not (received and bridge.receive_refused) and time.monotonic() < deadline_s:
                clock.advance(0.002)  # the bridge's timer takes the interface's frames
                received.extend(robot.receive())
                time.sleep(0.001)
            received.extend(robot.receive())
            assert [(f.arbitration_id, f.data) for f in received] == [(0x101, bytes(8))]
            assert bridge.receive_refused == 1  # an extended id has no place on this bus
            assert [entry.sender for entry in world.bus.log] == ["robot", NODE]
            assert peer.recv(0.05) is None  # the interface's own frame is not sent back out
    finally:
        peer.shutdown()
