"""Input readers on simulated ports: checked commands, counters judged over a window, edges taken
between consecutive accepted frames, every bad frame counted once at the poll time, and the
ports' own failures (their `LinkState`) as faults that last as long as they do."""

from __future__ import annotations

from dataclasses import replace

import pytest

from bywire.can_frame import CanFrame
from bywire.config import TimeoutsSection
from bywire.control.command_edges import CommandEdges
from bywire.control.input_stage import Verdict
from bywire.control.rc_mapping import RcMapping
from bywire.control.validity import is_fresh
from bywire.hal.ports import LINK_UP, LinkState
from bywire.hal.simulated.can_bus import SimCanBus
from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.uart import SimUart
from bywire.model import ControlCommand, ControlMode, Gear, LightsCommand, MovementCommand
from bywire.protocol import dbc, ibus
from bywire.runtime.readers import (
    COUNTER_MISS_LIMIT,
    COUNTER_WINDOW,
    CanReader,
    IbusReader,
    LinkFaults,
    arrival,
)
from bywire.runtime.recent_fault import FAULT_HOLD_S, RecentFault
from bywire.runtime.rx_checks import RxCheck, rx_checks

CHANNELS = (1750, 1500, 1500, 1500, 1500, 1000, 1500) + (1500,) * 7
FRAME = ibus.encode_frame(CHANNELS)
CORRUPT = FRAME[:-1] + bytes([FRAME[-1] ^ 0xFF])
FAILSAFE = ibus.encode_frame((1500, 900) + (1500,) * 12)
MOVEMENT_ID = dbc.frame_id(MovementCommand)


class Link:
    """A sender and the controller's reader on one simulated bus."""

    def __init__(self, checks: tuple[RxCheck, ...] | None = None) -> None:
        self.clock = VirtualClock()
        bus = SimCanBus(self.clock)
        self.sender = bus.attach("hlc", tx_mailboxes=64)
        self.reader = CanReader(bus.attach("bywire", True), checks)

    def queue(self, *counters: int, data: bytes | None = None) -> None:
        for counter in counters:
            command = MovementCommand(0.1, 0.2, 0.0, Gear.FORWARD, counter)
            frame_id, payload = dbc.encode_command(command)
            self.sender.send(CanFrame(frame_id, data if data is not None else payload))

    def send(self, *counters: int, data: bytes | None = None) -> list[int]:
        """Send movement commands with these counters; the counters of the accepted ones."""
        self.queue(*counters, data=data)
        return self.poll()[1]

    def poll(self, after_s: float = 0.05) -> tuple[float, list[int]]:
        self.clock.advance(after_s)
        now = self.clock.now()
        return now, [stamped.value.counter for stamped in self.reader.poll(now)]

    def settle(self, first: int = 0) -> int:
        """ControlCommand frames (no request) for one command timeout: the link is established.
        The next counter."""
        counter = first
        while self.clock.now() < 0.1 or counter - first < 6:
            self.control(counter)
            counter += 1
        return counter

    def control(self, counter: int, *, re_enable: bool = False, stop: bool = False) -> CommandEdges:
        """One ControlCommand frame after 20 ms; the edges the reader took from it."""
        frame_id, payload = dbc.encode_command(ControlCommand(stop, re_enable, counter))
        self.sender.send(CanFrame(frame_id, payload))
        self.clock.advance(0.02)
        self.reader.poll(self.clock.now())
        return self.reader.control_edges


# --- RecentFault -------------------------------------------------------------------------------


def test_a_fault_flag_is_held_for_exactly_the_hold_time_inclusive() -> None:
    fault = RecentFault()
    fault.happened(1.0)
    assert fault.count == 1
    assert FAULT_HOLD_S == 0.5
    assert fault.active(1.5)
    assert not fault.active(1.5001)


# --- CAN: counters ------------------------------------------------------------------------------


def test_consecutive_counters_are_accepted_and_wrap() -> None:
    assert Link().send(14, 15, 0, 1) == [14, 15, 0, 1]


def test_an_identical_repeat_is_dropped_harmlessly_and_the_sequence_goes_on() -> None:
    # A driver that sends every frame twice (or a redundant scheme) is no second sender.
    link = Link()
    assert link.send(3, 4, 4, 5) == [3, 4, 5]
    assert link.reader.verdicts[Verdict.REPEAT] == 1
    assert link.reader.rejected[dbc.RejectReason.COUNTER] == 0
    assert link.reader.reject_faults.count == 0
    assert not link.reader.untrusted


def test_a_repeat_asking_for_something_else_is_a_second_sender() -> None:
    link = Link()
    assert link.send(3, 4) == [3, 4]
    forged = dbc.encode_command(MovementCommand(1.0, 0.0, 0.0, Gear.FORWARD, 4))[1]
    assert link.send(4, data=forged) == []
    assert link.reader.verdicts[Verdict.CONFLICT] == 1
    assert link.reader.untrusted


def test_one_lost_frame_costs_one_frame_and_leaves_the_message_trusted() -> None:
    link = Link()
    assert link.send(3, 5, 6) == [3, 6]  # 5 skipped a counter; 6 follows 5 and is accepted
    assert link.reader.states[MOVEMENT_ID].window == (False, True, False)
    assert not link.reader.untrusted


def test_a_second_sender_taking_over_the_sequence_is_caught_by_the_computers_next_frame() -> None:
    """Hazard 10 and issue 30: a second node sends the computer's next counter half a period
    after the computer, asking for something else. Its one frame is used; the computer's own
    next frame then repeats that counter asking for something else: a conflict, the id
    untrusted. Before, its frames drove the throttle for 55 ms (three misses in a window)."""
    link = Link()
    own = MovementCommand(0.1, 0.2, 0.0, Gear.FORWARD, 0)
    taken: list[float] = []
    for counter in range(8):
        link.sender.send(
            CanFrame(MOVEMENT_ID, dbc.encode_command(replace(own, counter=counter))[1])
        )
        link.clock.advance(0.01)
        taken += [c.value.throttle_norm for c in link.reader.poll(link.clock.now())]  # type: ignore[attr-defined]
        if counter >= 5:  # the impostor, half a period later, with the computer's next counter
            forged = replace(own, throttle_norm=0.8, counter=counter + 1)
            link.sender.send(CanFrame(MOVEMENT_ID, dbc.encode_command(forged)[1]))
        link.clock.advance(0.01)
        taken += [c.value.throttle_norm for c in link.reader.poll(link.clock.now())]  # type: ignore[attr-defined]
    assert taken.count(0.8) == 1  # one period of its request, then nothing
    assert link.reader.verdicts[Verdict.CONFLICT] >= 1
    assert link.reader.untrusted


def test_a_second_sender_whose_frames_fail_to_conflict_is_still_caught_by_its_misses() -> None:
    """Counters out of step (a replaying node) cost trust over the window as before."""
    link = Link()
    interleaved = [c for k in range(8) for c in (2 * k % 16, (2 * k + 5) % 16)]
    accepted = link.send(*interleaved)
    assert sum(link.reader.states[MOVEMENT_ID].window) >= COUNTER_MISS_LIMIT
    assert link.reader.untrusted
    assert len(accepted) < 3


def test_an_untrusted_message_needs_a_whole_window_of_good_frames() -> None:
    link = Link()
    assert link.send(0, 2, 4, 6) == [0]  # three skips in a row
    assert link.reader.untrusted
    good = [(7 + k) % 16 for k in range(COUNTER_WINDOW)]
    accepted = link.send(*good)
    assert accepted == good[-1:]  # dropped until the window is clean, then used
    assert not link.reader.untrusted
    assert link.reader.untrusted_frames == COUNTER_WINDOW - 1


def test_a_frame_the_codec_could_not_read_restarts_the_sequence_instead_of_a_miss() -> None:
    link = Link()
    _, payload = dbc.encode_command(MovementCommand(0.0, 0.0, 0.0, Gear.FORWARD, 4))
    bad = bytes([payload[0] ^ 1, *payload[1:]])
    assert link.send(3) == [3]
    assert link.send(4, data=bad) == []
    assert link.send(5) == [5]
    assert True not in link.reader.states[MOVEMENT_ID].window


def test_a_forgery_after_an_unreadable_frame_is_judged_against_the_last_frame_read() -> None:
    """Issue 30, finding 1: a second node answered each frame with a bad CRC and then a forgery
    carrying the counter just used; the unreadable frame reset the expected counter, so the
    forgery was accepted (full right lock at 0.78 m/s)."""
    link = Link()
    assert link.send(3) == [3]
    _, payload = dbc.encode_command(MovementCommand(0.0, 0.0, 0.0, Gear.FORWARD, 4))
    assert link.send(4, data=bytes([payload[0] ^ 1, *payload[1:]])) == []
    forged = dbc.encode_command(MovementCommand(1.0, 0.0, 0.0, Gear.FORWARD, 3))[1]
    assert link.send(3, data=forged) == []
    assert link.reader.untrusted


def test_a_counter_skipped_after_an_unreadable_frame_then_from_the_bus_is_a_second_sender() -> None:
    """Issue 41, finding 9: a second node answered the computer's frame 3 with a bad CRC and a
    forgery carrying 5; one unreadable frame allows one skipped counter, so the forgery was
    taken, and the computer's own 4 then counted as a stale counter (a miss), not a conflict."""
    link = Link()
    assert link.send(3) == [3]
    _, payload = dbc.encode_command(MovementCommand(0.0, 0.0, 0.0, Gear.FORWARD, 4))
    assert link.send(4, data=bytes([payload[0] ^ 1, *payload[1:]])) == []
    forged = dbc.encode_command(MovementCommand(1.0, 0.0, 0.0, Gear.FORWARD, 5))[1]
    assert link.send(5, data=forged) == [5]  # one period: a forgery with a plausible counter
    assert link.send(4) == []  # the computer's own frame: the counter the forgery skipped
    assert link.reader.verdicts[Verdict.CONFLICT] == 1
    assert link.reader.untrusted


def _forged(counter: int) -> bytes:
    return dbc.encode_command(MovementCommand(1.0, 0.0, 0.0, Gear.FORWARD, counter))[1]


@pytest.mark.parametrize(
    "between",
    [
        [],  # the computer's skipped counter next
        [("forged", 6)],  # one more forgery in sequence, which a first fix forgot the skip by
        [("replayed", 3)],  # the computer's own frame 3 again: stale, a miss, moves nothing
        [("forged", 11)],  # a miss as far ahead as a miss goes, to push the skip out of memory
        [("forged", 11), ("forged", 1)],  # two of them: then the computer's frame is a third
    ],
)
def test_a_skipped_counter_then_from_the_bus_distrusts_the_id_whatever_comes_between(
    between: list[tuple[str, int]],
) -> None:
    """Issue 41, finding 9, and what an adversary tries around its fix: a second node answers
    the computer's frame 3 with a bad CRC and a forgery carrying 5; the computer's own 4 then
    carries a counter the sequence skipped."""
    link = Link()
    assert link.send(*range(10, 16), *range(4)) == [*range(10, 16), *range(4)]
    _, payload = dbc.encode_command(MovementCommand(0.0, 0.0, 0.0, Gear.FORWARD, 4))
    assert link.send(4, data=bytes([payload[0] ^ 1, *payload[1:]])) == []
    assert link.send(5, data=_forged(5)) == [5]  # one period: a plausible counter, no MAC
    for how, counter in between:
        link.send(counter, data=_forged(counter) if how == "forged" else None)
    link.send(4, 5, 6)  # the computer goes on
    assert link.reader.untrusted


def test_a_burst_taking_over_the_sequence_is_caught_by_the_computers_next_frame() -> None:
    # Two forged frames with the computer's next two counters: its own next frame is then one
    # behind, which once counted as a stale counter (a miss), not a second sender.
    link = Link()
    assert link.send(3) == [3]
    assert link.send(4, data=_forged(4)) == [4]
    assert link.send(5, data=_forged(5)) == [5]
    assert link.send(4) == []
    assert link.reader.untrusted


def test_an_honest_computers_damaged_frames_still_cost_nothing() -> None:
    """The guard of finding 9: the counters skipped over unreadable frames never come again
    from one sender, so its doubled and damaged frames stay trusted."""
    link = Link()
    _, payload = dbc.encode_command(MovementCommand(0.0, 0.0, 0.0, Gear.FORWARD, 4))
    bad = bytes([payload[0] ^ 1, *payload[1:]])
    assert link.send(3, 3) == [3]
    assert link.send(4, 4, data=bad) == []
    assert link.send(5, 5, 6, 6) == [5, 6]
    assert link.reader.verdicts[Verdict.CONFLICT] == 0
    assert True not in link.reader.states[MOVEMENT_ID].window
    assert not link.reader.untrusted


def test_corrupt_frames_are_counted_per_frame_and_flagged_at_the_poll_time() -> None:
    link = Link()
    _, payload = dbc.encode_command(MovementCommand(0.0, 0.0, 0.0, Gear.FORWARD, 0))
    bad = bytes([payload[0] ^ 1, *payload[1:]])
    link.sender.send(CanFrame(MOVEMENT_ID, bad))
    link.sender.send(CanFrame(MOVEMENT_ID, bad))
    now, accepted = link.poll()
    assert accepted == []
    assert link.reader.rejected[dbc.RejectReason.CHECKSUM] == 2
    assert link.reader.reject_faults.count == 2
    assert link.reader.reject_faults.last_at == now


def test_a_frame_with_an_unknown_id_is_skipped_and_the_rest_of_the_batch_still_read() -> None:
    link = Link()
    link.sender.send(CanFrame(0x7FF, b"\x00" * 8))
    link.sender.send(CanFrame(0x7FE, b"\x00" * 8))
    assert link.send(1) == [1]
    assert link.reader.ignored_frames == 2


# --- CAN: ControlCommand edges -------------------------------------------------------------------


def test_a_re_enable_edge_is_a_change_between_consecutive_accepted_frames() -> None:
    link = Link()
    n = link.settle()
    assert link.control(n) == CommandEdges()
    assert link.control(n + 1, re_enable=True) == CommandEdges(re_enable=True)
    assert link.control(n + 2, re_enable=True) == CommandEdges()  # held: no edge


def test_a_re_enable_held_across_a_gap_is_not_an_edge() -> None:
    """Hazard row 2: 1, a 150 ms gap, 1 again: the first frame after the gap has no reference."""
    link = Link()
    n = link.settle()
    link.control(n + 1, re_enable=True)
    link.clock.advance(0.15)
    assert link.control(n + 2, re_enable=True) == CommandEdges()
    n = link.settle(n + 3)
    assert link.control(n, re_enable=True) == CommandEdges(re_enable=True)


def test_a_re_enable_in_the_burst_after_a_gap_is_not_an_edge() -> None:
    """Found by bywire verify: with the cable out, the computer's frames wait in its transmit
    queue (a 0, then the 1 it asked for); plugged in again, they arrive back to back. A request
    that old is no deliberate act: edges count once the link has been back a command timeout."""
    link = Link()
    n = link.settle()
    link.clock.advance(0.5)  # the cable out
    assert link.control(n) == CommandEdges()
    assert link.control(n + 1, re_enable=True) == CommandEdges()  # 20 ms after the link is back
    for counter in range(n + 2, n + 6):
        assert link.control(counter) == CommandEdges()
    assert link.control(n + 6, re_enable=True) == CommandEdges(re_enable=True)  # asked again


def test_a_re_enable_after_a_rejected_frame_is_not_an_edge() -> None:
    link = Link()
    link.control(0)
    frame_id, payload = dbc.encode_command(ControlCommand(False, False, 1))
    link.sender.send(CanFrame(frame_id, payload[:-1] + bytes((payload[-1] ^ 0x5A,))))
    assert link.control(2, re_enable=True) == CommandEdges()


def test_a_remote_stop_counts_as_arriving_on_the_first_frame_that_carries_it() -> None:
    link = Link()
    assert link.control(0, stop=True) == CommandEdges(remote_stop=True)
    assert link.control(1, stop=True) == CommandEdges()
    link.clock.advance(0.15)
    assert link.control(2, stop=True) == CommandEdges(remote_stop=True)  # the safe direction


# --- a stop always gets through (issue 29) -------------------------------------------------------


def _raw_control(link: Link, counter: int, *, stop: bool) -> None:
    frame_id, payload = dbc.encode_command(ControlCommand(stop, False, counter))
    link.sender.send(CanFrame(frame_id, payload))
    link.clock.advance(0.02)
    link.reader.poll(link.clock.now())


def test_a_stop_in_an_intact_frame_arrives_whatever_its_counter() -> None:
    link = Link()
    counter = link.settle()
    before = link.reader.stop_requests
    _raw_control(link, counter + 3, stop=True)  # a skipped counter: a miss, the stop passes
    assert link.reader.rejected[dbc.RejectReason.COUNTER] == 1
    assert link.reader.stop_requests == before + 1


def test_a_stop_arrives_on_an_untrusted_id_and_a_re_enable_does_not() -> None:
    link = Link()
    counter = link.settle()
    frame_id, payload = dbc.encode_command(ControlCommand(False, True, counter - 1))
    link.sender.send(CanFrame(frame_id, payload))  # a second sender: the counter just used
    link.clock.advance(0.02)
    link.reader.poll(link.clock.now())
    assert link.reader.untrusted
    before = link.reader.stop_requests
    _raw_control(link, counter, stop=True)
    assert link.reader.stop_requests == before + 1
    assert link.control(counter + 1, re_enable=True) == CommandEdges()


def test_a_stop_held_by_every_frame_is_one_arrival_and_a_corrupt_one_none() -> None:
    link = Link()
    counter = link.settle()
    before = link.reader.stop_requests
    _raw_control(link, counter, stop=True)
    arrivals = link.reader.stop_requests
    assert arrivals > before  # the frame may be counted by both paths: one arrival
    for offset in range(1, 10):  # held by every later frame
        _raw_control(link, counter + offset, stop=True)
    assert link.reader.stop_requests == arrivals
    frame_id, payload = dbc.encode_command(ControlCommand(True, False, 0))
    link.clock.advance(0.2)
    link.sender.send(CanFrame(frame_id, payload[:-1] + bytes((payload[-1] ^ 0x5A,))))
    link.clock.advance(0.02)
    link.reader.poll(link.clock.now())
    assert link.reader.stop_requests == arrivals  # a bad CRC carries nothing, not even a stop


def _two_senders_on_the_lights_id(link: Link) -> None:
    frame_id = dbc.frame_id(LightsCommand)
    for counter in (0, 1, 0, 1, 0, 1, 0, 1):  # their counters interleave
        payload = dbc.encode_command(LightsCommand(False, False, True, False, counter))[1]
        link.sender.send(CanFrame(frame_id, payload))
    link.poll()


def test_an_untrusted_lights_id_affects_the_lights_alone() -> None:
    link = Link()
    _two_senders_on_the_lights_id(link)
    assert link.reader.untrusted_kinds == {LightsCommand}
    assert not link.reader.untrusted


def test_whether_an_untrusted_id_stops_can_driving_is_its_rows_not_a_list_of_ids() -> None:
    """A new command message stops CAN driving when a second sender takes its id, unless its row
    says it moves nothing (a horn, added by hand, once stopped the robot as the lamps did)."""
    rows = rx_checks(TimeoutsSection())
    moving = {row.kind: row.moves_the_robot for row in rows}
    assert (moving[ControlCommand], moving[MovementCommand], moving[LightsCommand]) == (
        True,
        True,
        False,
    )
    moving_lights = tuple(
        replace(row, moves_the_robot=True) if row.kind is LightsCommand else row for row in rows
    )
    link = Link(moving_lights)
    _two_senders_on_the_lights_id(link)
    assert link.reader.untrusted


# --- IBUS ----------------------------------------------------------------------------------------


class Receiver:
    """An RC receiver's UART and the controller's reader on it."""

    def __init__(self) -> None:
        self.clock = VirtualClock()
        self.uart = SimUart(self.clock)
        self.reader = IbusReader(self.uart, RcMapping())

    def poll_after(self, data: bytes) -> float:
        """Send `data`, let it arrive, poll; the poll time."""
        self.uart.transmit(data)
        self.clock.advance(0.05)
        now = self.clock.now()
        self.reader.poll(now)
        return now


@pytest.mark.parametrize("chunk", [1, 5, 32, 64])
def test_ibus_reader_returns_the_newest_request_stamped_when_its_last_byte_arrived(
    chunk: int,
) -> None:
    rx = Receiver()
    for start in range(0, len(FRAME), chunk):
        rx.uart.transmit(FRAME[start : start + chunk])
    rx.clock.advance(0.01)
    stamped = rx.reader.poll(rx.clock.now())
    assert stamped is not None
    # the frame's last stop bit, not the poll 10 ms later: bytes that waited are not fresh
    assert stamped.received_at == pytest.approx(rx.uart.line_free_at_s, abs=1e-12)
    assert stamped.received_at < rx.clock.now() - 0.005
    assert stamped.value is not None
    assert stamped.value.steering_norm == pytest.approx(0.5)


def test_rc_frames_that_waited_while_the_loop_was_busy_are_stale() -> None:
    """The transmitter's last frame arrives, then the loop is busy for 150 ms: read now, the
    frame is 150 ms old, stale for a 100 ms timeout (a read-time stamp would call it fresh)."""
    rx = Receiver()
    rx.uart.transmit(FRAME)
    rx.clock.advance(0.15)
    now = rx.clock.now()
    stamped = rx.reader.poll(now)
    assert stamped is not None
    assert not is_fresh(stamped, now, 0.100)


def test_ibus_reader_marks_a_failsafe_frame_as_suspect() -> None:
    rx = Receiver()
    rx.uart.transmit(FAILSAFE)
    rx.clock.advance(0.01)
    stamped = rx.reader.poll(rx.clock.now())
    assert stamped is not None
    assert stamped.value is None


def test_one_failsafe_frame_anywhere_in_a_batch_makes_the_batch_suspect() -> None:
    rx = Receiver()
    rx.uart.transmit(FAILSAFE + FRAME)
    rx.clock.advance(0.05)
    stamped = rx.reader.poll(rx.clock.now())
    assert stamped is not None
    assert stamped.value is None


def test_one_frame_at_stop_anywhere_in_a_batch_means_stop() -> None:
    # The loop held up by a hanging write reads a bouncing switch's frames at once: STOP, then
    # RC again. A move to STOP acts on one frame, so the batch reads STOP (with its sticks).
    at_stop = ibus.encode_frame((*CHANNELS[:6], 1000, *CHANNELS[7:]))
    rx = Receiver()
    rx.uart.transmit(FRAME + at_stop + FRAME)
    rx.clock.advance(0.05)
    stamped = rx.reader.poll(rx.clock.now())
    assert stamped is not None
    assert stamped.value is not None
    assert stamped.value.mode is ControlMode.STOP
    assert stamped.value.steering_norm == pytest.approx(0.5)
    rx.uart.transmit(FRAME)
    rx.clock.advance(0.01)
    alone = rx.reader.poll(rx.clock.now())
    assert alone is not None
    assert alone.value is not None
    assert alone.value.mode is ControlMode.RC


def test_a_batch_is_between_positions_only_if_no_frame_of_it_was_at_the_stop_position() -> None:
    """docs/SAFETY.md row 72: a switch read between positions is STOP, but no stay at STOP; a
    batch with one frame at the STOP position is a stay's frame, whatever else it read."""
    at_stop = ibus.encode_frame((*CHANNELS[:6], 1000, *CHANNELS[7:]))
    between = ibus.encode_frame((*CHANNELS[:6], 1250, *CHANNELS[7:]))
    for frames, mode_between in (
        (between, True),
        (FRAME + between, True),
        (between + FRAME, True),
        (at_stop + between, False),
        (between + at_stop + FRAME, False),
        (at_stop, False),
    ):
        rx = Receiver()
        rx.uart.transmit(frames)
        rx.clock.advance(0.05)
        stamped = rx.reader.poll(rx.clock.now())
        assert stamped is not None
        assert stamped.value is not None
        assert (stamped.value.mode, stamped.value.mode_between) == (ControlMode.STOP, mode_between)


def test_each_frame_is_mapped_as_it_reads_even_after_a_run_of_equal_ones() -> None:
    """The reader maps a run of equal frames once; the frame that differs (a switch to STOP, a
    stick back to centre, a failsafe) is mapped anew, and so is the first one after it."""
    at_stop = ibus.encode_frame((*CHANNELS[:6], 1000, *CHANNELS[7:]))
    rx = Receiver()
    seen = []
    for frame in (FRAME, FRAME, FRAME, at_stop, FAILSAFE, FRAME, FRAME):
        rx.uart.transmit(frame)
        rx.clock.advance(0.01)
        stamped = rx.reader.poll(rx.clock.now())
        assert stamped is not None
        seen.append(None if stamped.value is None else stamped.value.mode)
    rc, stop = ControlMode.RC, ControlMode.STOP
    assert seen == [rc, rc, rc, stop, None, rc, rc]


def test_checksum_faults_are_counted_per_bad_frame_and_stamped_with_the_poll_time() -> None:
    rx = Receiver()
    rx.poll_after(CORRUPT + CORRUPT + FRAME)
    second_s = rx.poll_after(CORRUPT + FRAME)
    assert rx.reader.checksum_faults.count == 3
    assert rx.reader.checksum_faults.last_at == second_s


def test_resyncs_are_counted_per_realignment_and_stamped_with_the_poll_time() -> None:
    rx = Receiver()
    rx.poll_after(b"\x01\x02\x03" + FRAME + b"\x06" + FRAME)
    second_s = rx.poll_after(b"\x04\x05" + FRAME)
    assert rx.reader.resync_faults.count == 3
    assert rx.reader.resync_faults.last_at == second_s


def test_the_reader_keeps_the_newest_raw_channels_and_stamps_its_parser() -> None:
    rx = Receiver()
    assert rx.reader.last_channels is None
    rx.poll_after(FRAME)
    assert rx.reader.last_channels == CHANNELS
    assert rx.reader.parser.last_frame_at == rx.uart.arrived_at_s == rx.uart.line_free_at_s


# --- CAN: when a frame arrived ------------------------------------------------------------------


def test_a_command_is_stamped_when_its_frame_arrived_not_when_the_loop_read_it() -> None:
    link = Link()
    link.queue(1)
    link.clock.advance(0.001)  # on the wire: the frame is in the controller's receive queue
    arrived_at = link.clock.now()
    link.clock.advance(0.15)  # the loop was busy: the frame waited, the sender fell silent
    now = link.clock.now()
    (stamped,) = link.reader.poll(now)
    assert stamped.received_at <= arrived_at
    assert stamped.received_at > 0.0
    # 151 ms old: stale for a 100 ms timeout, however fresh it looks to the loop
    assert not is_fresh(stamped, now, 0.100)


def test_a_stamp_from_the_future_or_none_is_not_believed() -> None:
    now = 2.0
    assert arrival(CanFrame(MOVEMENT_ID, b"", 1.5), now) == 1.5
    assert arrival(CanFrame(MOVEMENT_ID, b"", 2.5), now) == now
    assert arrival(CanFrame(MOVEMENT_ID, b""), now) == now


def test_only_ids_with_a_receive_check_are_taken() -> None:
    clock = VirtualClock()
    bus = SimCanBus(clock)
    sender = bus.attach("hlc", tx_mailboxes=8)
    movement_only = [
        check for check in rx_checks(TimeoutsSection()) if check.kind is not LightsCommand
    ]
    reader = CanReader(bus.attach("bywire", True), movement_only)
    frame_id, payload = dbc.encode_command(LightsCommand(True, False, False, False, 0))
    sender.send(CanFrame(frame_id, payload))
    clock.advance(0.01)
    assert reader.poll(clock.now()) == []
    assert reader.ignored_frames == 1


# --- the ports' own failures ------------------------------------------------------------------


def test_a_link_down_is_a_fault_at_every_poll_it_lasts_and_one_loss_however_long() -> None:
    faults = LinkFaults()
    faults.read(LINK_UP, 0.5)
    assert not faults.down.active(0.5)
    lost = LinkState(down=True, receive_failures=1)
    for now in (1.0, 1.5):  # the same value (a simulated port) and an equal one (a Linux port)
        faults.read(lost, now)
    faults.read(LinkState(down=True, receive_failures=1), 2.0)
    assert (faults.down.count, faults.down.last_at) == (1, 2.0)
    faults.read(LinkState(receive_failures=1), 2.1)  # back: the flag is held, not renewed
    assert faults.down.active(2.0 + FAULT_HOLD_S)
    assert not faults.down.active(2.0 + FAULT_HOLD_S + 0.01)
    # The receive that lost the link is up as long as the loss.
    assert (faults.receive_failed.count, faults.receive_failed.last_at) == (1, 2.0)


def test_failed_reopens_and_receives_are_faults_when_their_counts_grow() -> None:
    faults = LinkFaults()
    faults.read(LinkState(reopen_failures=2, receive_failures=1), 1.0)
    faults.read(LinkState(reopen_failures=2, receive_failures=1), 1.2)
    assert (faults.reopen_failed.count, faults.reopen_failed.last_at) == (2, 1.0)
    faults.read(LinkState(reopen_failures=3, receive_failures=1), 1.4)
    assert (faults.reopen_failed.count, faults.reopen_failed.last_at) == (3, 1.4)
    assert faults.receive_failed.last_at == 1.0
    # A failure that came and went between two polls is still seen, by its count.
    faults.read(LinkState(reopen_failures=3, receive_failures=2), 3.0)
    assert (faults.receive_failed.count, faults.receive_failed.last_at) == (2, 3.0)
    assert not faults.down.active(3.0)


def test_the_failures_of_a_loss_last_as_long_as_the_loss() -> None:
    # Nothing can be reported while the link is down: what lost it, or kept it lost, is named
    # by the first reports after it (a re-open back-off grows to 2 s, far past the hold).
    faults = LinkFaults()
    faults.read(LinkState(receive_failures=1), 0.5)  # a frame dropped, long before the loss
    faults.read(LinkState(down=True, receive_failures=2), 1.0)  # the receive that lost it
    faults.read(LinkState(down=True, reopen_failures=1, receive_failures=2), 1.2)
    for tenth in range(13, 41):  # a poll every 0.1 s (the loop's are 10 ms apart)
        faults.read(LinkState(down=True, reopen_failures=1, receive_failures=2), tenth / 10)
    faults.read(LinkState(reopen_failures=1, receive_failures=2), 4.1)
    for failed in (faults.down, faults.reopen_failed, faults.receive_failed):
        assert failed.last_at == 4.0
        assert failed.active(4.0 + FAULT_HOLD_S)
        assert not failed.active(4.0 + FAULT_HOLD_S + 0.01)
    assert (faults.receive_failed.count, faults.reopen_failed.count) == (2, 1)
    # A failure that ended before an unrelated loss is not renewed by it.
    quiet = LinkFaults()
    quiet.read(LinkState(receive_failures=1), 0.5)
    quiet.read(LinkState(down=True, receive_failures=1), 2.0)
    quiet.read(LinkState(down=True, receive_failures=1), 2.5)
    assert quiet.receive_failed.last_at == 0.5


def test_a_can_port_gone_bus_off_is_a_fault_though_no_frame_arrives() -> None:
    clock = VirtualClock()
    port = SimCanBus(clock).attach("bywire", True, accept_ids=dbc.received_ids())
    reader = CanReader(port)
    reader.poll(clock.now())
    port.enter_bus_off()
    for _ in range(3):
        clock.advance(0.4)
        assert reader.poll(clock.now()) == []
        assert reader.link_faults.down.last_at == clock.now()
    port.recover_bus_off()
    clock.advance(0.4)
    reader.poll(clock.now())
    assert reader.link_faults.down.last_at == pytest.approx(1.2)
    assert reader.link_faults.down.count == 1


def test_frames_dropped_from_a_full_receive_queue_are_failed_receives() -> None:
    clock = VirtualClock()
    bus = SimCanBus(clock)
    sender = bus.attach("hlc", tx_mailboxes=8)
    reader = CanReader(bus.attach("bywire", True, rx_capacity=2))
    for counter in range(3):
        frame_id, payload = dbc.encode_command(
            MovementCommand(0.0, 0.0, 0.0, Gear.FORWARD, counter)
        )
        sender.send(CanFrame(frame_id, payload))
    clock.advance(0.01)
    assert [stamped.value.counter for stamped in reader.poll(clock.now())] == [0, 1]
    assert reader.link_faults.receive_failed.count == 1
    assert reader.link_faults.receive_failed.active(clock.now())
    assert not reader.link_faults.down.active(clock.now())


def test_an_rc_port_that_is_gone_is_a_fault_though_no_byte_arrives() -> None:
    clock = VirtualClock()
    uart = SimUart(clock)
    reader = IbusReader(uart, RcMapping())
    uart.transmit(FRAME)
    clock.advance(0.01)
    assert reader.poll(clock.now()) is not None
    uart.fail()
    uart.transmit(FRAME)
    clock.advance(0.01)
    assert reader.poll(clock.now()) is None  # what the line carried meanwhile is lost
    assert reader.link_faults.down.last_at == clock.now()
    uart.restore()
    uart.transmit(FRAME)
    clock.advance(0.01)
    assert reader.poll(clock.now()) is not None
    assert reader.link_faults.down.last_at == pytest.approx(0.02)
