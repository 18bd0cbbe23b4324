"""Simulated CAN bus: time on the wire, arbitration by id, filters, faults, flood load, log."""

from __future__ import annotations

import itertools

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bywire.can_frame import CanFrame
from bywire.errors import FrameError
from bywire.hal.simulated.can_bus import LoggedFrame, SimCanBus
from bywire.hal.simulated.clock import VirtualClock
from bywire.protocol.bittiming import frame_bits

BIT_S = 1 / 500_000
EIGHT_BYTES = bytes(range(8))


def bus_with_two_nodes() -> tuple[VirtualClock, SimCanBus]:
    clock = VirtualClock()
    return clock, SimCanBus(clock)


def test_a_frame_arrives_after_its_time_on_the_wire_and_not_at_its_sender() -> None:
    clock, bus = bus_with_two_nodes()
    sender = bus.attach("hlc")
    receiver = bus.attach("bywire")
    clock.advance(0.001)
    assert sender.send(CanFrame(0x101, EIGHT_BYTES))
    clock.advance(134 * BIT_S)
    assert receiver.receive() == []
    clock.advance(2 * BIT_S)
    (frame,) = receiver.receive()
    assert frame.arbitration_id == 0x101
    assert frame.data == EIGHT_BYTES
    assert frame.timestamp_s == pytest.approx(0.001 + 135 * BIT_S)
    assert sender.receive() == []
    assert sender.frames_sent == 1
    assert receiver.frames_received == 1


def test_frames_queued_together_go_out_lowest_id_first_back_to_back() -> None:
    clock, bus = bus_with_two_nodes()
    reports = bus.attach("bywire")
    commands = bus.attach("hlc")
    listener = bus.attach("monitor")
    reports.send(CanFrame(0x205, EIGHT_BYTES))
    reports.send(CanFrame(0x202, bytes(4)))
    commands.send(CanFrame(0x101, EIGHT_BYTES))
    clock.advance(0.01)
    frames = listener.receive()
    assert [frame.arbitration_id for frame in frames] == [0x101, 0x202, 0x205]
    ends = [frame.timestamp_s for frame in frames]
    assert ends == pytest.approx([135 * BIT_S, (135 + 95) * BIT_S, (135 + 95 + 135) * BIT_S])


def test_a_frame_in_progress_is_never_preempted_by_a_lower_id() -> None:
    clock, bus = bus_with_two_nodes()
    flood = bus.attach("other")
    ours = bus.attach("hlc")
    listener = bus.attach("monitor")
    flood.send(CanFrame(0x300, EIGHT_BYTES))
    clock.advance(10 * BIT_S)
    ours.send(CanFrame(0x100, bytes(3)))
    clock.advance(0.01)
    frames = listener.receive()
    assert [frame.arbitration_id for frame in frames] == [0x300, 0x100]
    assert frames[1].timestamp_s == pytest.approx((135 + 85) * BIT_S)


def test_acceptance_filter_passes_only_its_ids() -> None:
    clock, bus = bus_with_two_nodes()
    sender = bus.attach("hlc")
    filtered = bus.attach("bywire", accept_ids={0x100, 0x101})
    for frame_id in (0x100, 0x101, 0x102, 0x300):
        sender.send(CanFrame(frame_id, bytes(3)))
        clock.advance(0.001)
    assert [frame.arbitration_id for frame in filtered.receive()] == [0x100, 0x101]
    filtered.set_filter(None)
    sender.send(CanFrame(0x7FF, b""))
    clock.advance(0.001)
    assert [frame.arbitration_id for frame in filtered.receive()] == [0x7FF]


def test_wake_on_receive_ends_the_wait_at_the_delivery_time() -> None:
    clock, bus = bus_with_two_nodes()
    sender = bus.attach("hlc")
    bus.attach("bywire", wake_on_receive=True)
    sender.send(CanFrame(0x101, EIGHT_BYTES))
    clock.wait_until(1.0)
    assert clock.now() == pytest.approx(135 * BIT_S)


def test_a_port_without_wake_lets_the_wait_run_to_its_deadline() -> None:
    clock, bus = bus_with_two_nodes()
    sender = bus.attach("hlc")
    receiver = bus.attach("bywire", wake_on_receive=False)
    sender.send(CanFrame(0x101, EIGHT_BYTES))
    clock.wait_until(1.0)
    assert clock.now() == 1.0
    assert len(receiver.receive()) == 1


def test_unplugged_bus_delivers_nothing_and_refuses_a_fourth_frame() -> None:
    clock, bus = bus_with_two_nodes()
    sender = bus.attach("bywire")
    receiver = bus.attach("hlc")
    bus.unplug()
    results = [sender.send(CanFrame(0x200 + index, bytes(2))) for index in (3, 1, 2, 0)]
    clock.advance(0.1)
    assert results == [True, True, True, False]
    assert receiver.receive() == []
    assert sender.pending == 3
    assert sender.send_refused == 1
    assert not sender.bus_off
    bus.plug()
    clock.advance(0.01)
    frames = receiver.receive()
    assert [frame.arbitration_id for frame in frames] == [0x201, 0x202, 0x203]
    assert frames[0].timestamp_s == pytest.approx(0.1 + frame_bits(2) * BIT_S)
    assert sender.pending == 0
    assert sender.send(CanFrame(0x204, b""))


def test_unplug_during_a_frame_keeps_it_for_after_plug() -> None:
    clock, bus = bus_with_two_nodes()
    sender = bus.attach("bywire")
    receiver = bus.attach("hlc")
    sender.send(CanFrame(0x200, bytes(2)))
    clock.advance(10 * BIT_S)
    bus.unplug()
    clock.advance(0.01)
    assert receiver.receive() == []
    bus.plug()
    clock.advance(0.01)
    assert [frame.arbitration_id for frame in receiver.receive()] == [0x200]


def test_bus_off_refuses_frames_and_drops_pending_until_recovered() -> None:
    clock, bus = bus_with_two_nodes()
    sender = bus.attach("bywire")
    receiver = bus.attach("hlc")
    bus.unplug()
    sender.send(CanFrame(0x200, b"\x01"))
    sender.enter_bus_off()
    assert sender.bus_off
    assert not sender.send(CanFrame(0x201, b"\x02"))
    bus.plug()
    clock.advance(0.01)
    assert receiver.receive() == []
    sender.recover_bus_off()
    assert sender.send(CanFrame(0x202, b"\x03"))
    clock.advance(0.01)
    assert [frame.data for frame in receiver.receive()] == [b"\x03"]


@pytest.mark.parametrize("load_fraction", [0.1, 0.5, 0.9, 1.0])
def test_flood_fills_its_share_of_the_bus(load_fraction: float) -> None:
    clock, bus = bus_with_two_nodes()
    bus.attach("bywire")
    bus.flood(load_fraction)
    clock.advance(1.0)
    measured = bus.bits_sent("flood") / 500_000
    assert measured == pytest.approx(load_fraction, abs=0.005)
    bus.stop_flood()
    before = bus.bits_sent("flood")
    clock.advance(0.1)
    assert bus.bits_sent("flood") - before <= 3 * 135  # only frames already queued


def test_flood_frames_lose_arbitration_to_ours() -> None:
    clock, bus = bus_with_two_nodes()
    ours = bus.attach("hlc")
    receiver = bus.attach("bywire", accept_ids={0x101})
    bus.flood(1.0, first_id=0x300)
    latencies_s = []
    for cycle in range(100):
        sent_s = 0.02 * cycle + 0.0001 * (cycle % 7)
        clock.advance(sent_s - clock.now())
        assert ours.send(CanFrame(0x101, EIGHT_BYTES))
        clock.advance(0.005)
        (frame,) = receiver.receive()
        latencies_s.append(frame.timestamp_s - sent_s)
    # At worst one flood frame finishes first, then ours takes its own time.
    assert max(latencies_s) <= 2 * 135 * BIT_S + 1e-9
    flood_ids = {entry.arbitration_id for entry in bus.log if entry.sender == "flood"}
    assert flood_ids
    assert min(flood_ids) >= 0x300


def test_log_records_every_delivered_frame_with_sender() -> None:
    clock, bus = bus_with_two_nodes()
    sender = bus.attach("hlc")
    bus.attach("bywire")
    seen: list[LoggedFrame] = []
    bus.add_monitor(seen.append)
    sender.send(CanFrame(0x102, b"\x01\x02\x03"))
    clock.advance(0.01)
    (entry,) = bus.log
    assert (entry.arbitration_id, entry.data, entry.sender) == (0x102, b"\x01\x02\x03", "hlc")
    assert entry.time_s == pytest.approx(85 * BIT_S)
    assert seen == [entry]


@pytest.mark.parametrize(("log_limit", "kept"), [(0, 0), (5, 5), (None, 20)])
def test_log_limit_caps_or_disables_the_log(log_limit: int | None, kept: int) -> None:
    clock = VirtualClock()
    bus = SimCanBus(clock, log_limit=log_limit)
    sender = bus.attach("hlc")
    for index in range(20):
        sender.send(CanFrame(0x100, bytes([index])))
        clock.advance(0.001)
    assert len(bus.log) == kept
    if kept:
        assert bus.log[-1].data == bytes([19])


def test_receive_queue_overflow_is_counted() -> None:
    clock, bus = bus_with_two_nodes()
    sender = bus.attach("hlc")
    receiver = bus.attach("bywire")
    for index in range(1030):
        sender.send(CanFrame(0x100, index.to_bytes(2, "little")))
        clock.advance(0.001)
    frames = receiver.receive()
    assert len(frames) == 1024
    assert receiver.rx_overflows == 6
    assert frames[0].data == b"\x00\x00"


@pytest.mark.parametrize("frame", [CanFrame(0x800, b""), CanFrame(0x100, bytes(9))])
def test_send_rejects_frames_classic_can_cannot_carry(frame: CanFrame) -> None:
    _, bus = bus_with_two_nodes()
    with pytest.raises(FrameError):
        bus.attach("hlc").send(frame)


def test_node_names_are_unique() -> None:
    _, bus = bus_with_two_nodes()
    bus.attach("hlc")
    with pytest.raises(ValueError, match="hlc"):
        bus.attach("hlc")


sends = st.lists(
    st.tuples(st.integers(0, 3), st.integers(0, 0x7FF), st.integers(0, 8), st.floats(0, 0.002)),
    min_size=1,
    max_size=30,
)


@given(sends)
def test_every_queued_frame_arrives_once_and_frames_never_overlap(
    plan: list[tuple[int, int, int, float]],
) -> None:
    clock = VirtualClock()
    bus = SimCanBus(clock)
    nodes = [bus.attach(f"node{index}") for index in range(4)]
    listener = bus.attach("listener")
    accepted: list[CanFrame] = []
    for node_index, frame_id, dlc, delay_s in plan:
        clock.advance(delay_s)
        frame = CanFrame(frame_id, bytes(dlc))
        if nodes[node_index].send(frame):
            accepted.append(frame)
    clock.advance(1.0)
    received = listener.receive()
    assert sorted((f.arbitration_id, f.data) for f in received) == sorted(
        (f.arbitration_id, f.data) for f in accepted
    )
    for earlier, later in itertools.pairwise(received):
        on_wire_s = frame_bits(len(later.data)) * BIT_S
        assert later.timestamp_s - earlier.timestamp_s >= on_wire_s - 1e-12
