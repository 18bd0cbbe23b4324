"""The CAN input stage: one row per command message, one pure step per frame (R-CANRX).

Each command message (ControlCommand, MovementCommand, LightsCommand) is a row of the receive
table (`bywire.runtime.rx_checks.RxCheck`: id, length, counter, CRC, period and timeout). Its
state, `MessageState`, is advanced by `message_step` on each frame's arrival, the frame already
decoded by the codec (`Decoded`: the command, or why the codec refused it). The verdict says
what becomes of the frame. The rules, as the adversarial pass of issue 30 taught them:

- **Unreadable** (wrong length, bad CRC): dropped. It says nothing of the sender's sequence, so
  it moves no counter: the next readable frame may skip it (one lost frame, not a miss), and a
  forgery after it is judged against the last frame that was read.
- **Out of range** (intact, a value outside its DBC range): dropped; its counter is followed.
- **The next counter** (allowing one step for each unreadable frame since the last read one, and
  MAX_STEP steps at the most): accepted.
- **A counter the sequence already passed** (the one followed, or one of the COUNTER_HISTORY - 1
  before it): judged against what the bus carried with it in the sequence followed (`seen`). The
  same request again: with the counter followed, an identical repeat (a driver that sends each
  frame twice, a redundant scheme), dropped, harmless, no miss; it keeps the link going but
  never renews the command's age, so a sender stuck on one frame times out; with an earlier
  counter, a stale frame (a replay): a miss, the counter not followed back. Anything else
  (another request, or a counter the sequence skipped) is two senders on one id: a *conflict*,
  and the id is untrusted at once. One sender's frames arrive in order, so the counters it
  skipped never come later and it never goes back (issue 41: a forger answering the computer's
  frame c with a bad-CRC frame and then c+2 had its forgery taken, and the computer's own c+1
  counted as a stale counter, a miss; two forgeries in every 16 frames steered the robot
  indefinitely). So a second sender that takes over the sequence (its frames carry the
  computer's next counters, one or a burst of them) is caught by the computer's own next frame,
  which carries a counter already passed: one period later at the most. Arrival times cannot
  tell a second sender's early frame from a burst (an adapter or a socketcand bridge that
  batches frames delivers a sender's own frames close together), so they are not used to judge
  it: a rule "two frames in one period" distrusted the ROS 2 bridge's own stream over
  socketcand.
- **Any other counter** (further ahead, up to COUNTER_MODULUS - COUNTER_HISTORY: frames lost
  without a trace): a *miss*; the counter is followed, the counters it skipped remembered as
  skipped, so one lost frame costs one frame, as panda does. A frame after more lost or
  unreadable frames in a row than that cannot be told from a counter already passed and is
  judged as one (a conflict: the safe side); with the default timeout (five periods) such a
  gap is a timeout first.
- **A gap** longer than the timeout: the sequence starts afresh.
- **Trust**: COUNTER_MISS_LIMIT misses among the last COUNTER_WINDOW frames, or one conflict, make
  the message untrusted; a whole window of good frames in a row trusts it again. An untrusted
  message's frames are judged, so trust can return, but never used.

ControlCommand's requests have rules of their own, also pure: `edges_step` takes its re-enable
and remote stop edges between consecutive accepted frames (a re-enable counts only once the
link has settled after a gap), and `stop_request_step` lets a remote stop through from any
intact frame, whatever its counter or trust (R-STOP-PASS).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from bywire.control.command_edges import CommandEdges, command_edges
from bywire.control.values import slot_init
from bywire.model import Command, ControlCommand, same_request

COUNTER_WINDOW = 16  # the last frames of a command message whose counters are judged
COUNTER_MISS_LIMIT = 3  # this many counter misses among them: the message is not trusted
COUNTER_MODULUS = 16
MAX_STEP = 4  # the furthest ahead a frame is taken in sequence: three unreadable ones before it
COUNTER_HISTORY = (COUNTER_MODULUS + MAX_STEP) // 2
"""The counter followed and those before it whose frames are remembered (10): more than half
the modulus, so that no frame can push a counter the sequence skipped out of the history in
one miss (a miss steps at most COUNTER_MODULUS - COUNTER_HISTORY = 6 ahead, and a skipped
counter sits at most MAX_STEP - 1 = 3 back: 9 < 10); pushing it out takes two misses, and the
frame that then carries it is a third, which distrusts the id."""


class Verdict(enum.Enum):
    """What becomes of one frame of a command message."""

    ACCEPTED = "accepted"
    REPEAT = "an identical repeat of the frame before: dropped, harmless"
    UNREADABLE = "unreadable (length or CRC): dropped"
    OUT_OF_RANGE = "a value outside its range: dropped"
    COUNTER = "a skipped or stale counter: dropped, a miss"
    CONFLICT = "a second sender on the id: dropped, the id untrusted"
    UNTRUSTED = "the id is untrusted: dropped"

    @property
    def used(self) -> bool:
        """The frame's command reaches the decision."""
        return self is Verdict.ACCEPTED


@dataclass(frozen=True, slots=True)
class Decoded:
    """A frame as the codec read it: its counter and command, or why it could not be used
    (`readable` False: length or CRC; `command` None but readable: a value out of range)."""

    readable: bool
    counter: int | None = None
    command: Command | None = None

    def __init__(
        self,
        readable: bool,
        counter: int | None = None,
        command: Command | None = None,
    ) -> None:
        object.__setattr__(self, "readable", readable)
        object.__setattr__(self, "counter", counter)
        object.__setattr__(self, "command", command)


slot_init(Decoded)


@dataclass(frozen=True, slots=True)
class MessageState:
    """One command message's receive state (see the module's rules)."""

    counter: int | None = None  # the counter followed: of the last intact frame followed
    seen: tuple[Command | None, ...] = ()  # what the bus carried with `counter` and each counter
    # before it in the sequence followed, newest first (None: skipped, or out of range), up to
    # COUNTER_HISTORY of them: for repeats and conflicts
    last_at: float | None = None  # when the last intact frame arrived
    lost: int = 0  # unreadable frames since the last intact one
    window: tuple[bool, ...] = ()  # the last COUNTER_WINDOW frames: True for a miss or conflict
    untrusted: bool = False

    def __init__(  # noqa: PLR0917
        self,
        counter: int | None = None,
        seen: tuple[Command | None, ...] = (),
        last_at: float | None = None,
        lost: int = 0,
        window: tuple[bool, ...] = (),
        untrusted: bool = False,
    ) -> None:
        object.__setattr__(self, "counter", counter)
        object.__setattr__(self, "seen", seen)
        object.__setattr__(self, "last_at", last_at)
        object.__setattr__(self, "lost", lost)
        object.__setattr__(self, "window", window)
        object.__setattr__(self, "untrusted", untrusted)


slot_init(MessageState)


def message_step(
    state: MessageState, frame: Decoded, arrived_at: float, timeout_s: float
) -> tuple[MessageState, Verdict]:
    """The next state and the frame's verdict; `arrived_at` is the frame's arrival stamp."""
    if not frame.readable or frame.counter is None:
        return _with(state, lost=state.lost + 1), Verdict.UNREADABLE
    if state.last_at is None or arrived_at - state.last_at > timeout_s:
        state = MessageState(window=state.window, untrusted=state.untrusted)
    verdict = _judged(state, frame)
    if verdict is Verdict.REPEAT:  # the link goes on; the command's age does not restart
        return _with(state, lost=state.lost, last_at=arrived_at), verdict
    miss = verdict in (Verdict.COUNTER, Verdict.CONFLICT)
    window = (*state.window, miss)[-COUNTER_WINDOW:]
    untrusted = _trust(state.untrusted, window, conflict=verdict is Verdict.CONFLICT)
    # A second sender's frame moves nothing, nor does a stale one: the sequence never goes back.
    followed = verdict is not Verdict.CONFLICT and _passed(state, frame.counter) is None
    new_state = MessageState(
        counter=frame.counter if followed else state.counter,
        seen=_seen_after(state, frame) if followed else state.seen,
        last_at=arrived_at,
        lost=0,
        window=window,
        untrusted=untrusted,
    )
    if verdict is Verdict.ACCEPTED and untrusted:
        return new_state, Verdict.UNTRUSTED
    return new_state, verdict


def _judged(state: MessageState, frame: Decoded) -> Verdict:
    """The verdict of an intact frame, before trust."""
    counter, command = frame.counter, frame.command
    if counter is None:
        return Verdict.UNREADABLE
    if state.counter is None or _in_sequence(state, counter):
        return _next(command)
    back = _passed(state, counter)
    if back is None:
        return Verdict.COUNTER
    carried = state.seen[back]  # what the bus carried with this counter in the sequence
    if command is None or carried is None or not same_request(command, carried):
        return Verdict.CONFLICT
    return Verdict.REPEAT if back == 0 else Verdict.COUNTER  # late, but the same: stale


def _in_sequence(state: MessageState, counter: int) -> bool:
    """Whether `counter` is next after the one followed (the unreadable frames allowing a step
    each, MAX_STEP at the most)."""
    if state.counter is None:
        return False
    ahead = (counter - state.counter) % COUNTER_MODULUS
    return 1 <= ahead <= min(1 + state.lost, MAX_STEP)


def _passed(state: MessageState, counter: int) -> int | None:
    """How far behind the counter followed `counter` is, when the sequence has passed it
    (0: the counter followed itself); None when it has not, or too long ago to remember."""
    if state.counter is None or _in_sequence(state, counter):
        return None
    back = (state.counter - counter) % COUNTER_MODULUS
    return back if back < len(state.seen) else None


def _seen_after(state: MessageState, frame: Decoded) -> tuple[Command | None, ...]:
    """`seen` once `frame` is followed: its request first, None for each counter it skipped."""
    if state.counter is None or frame.counter is None:
        return (frame.command,)
    skipped = (frame.counter - state.counter) % COUNTER_MODULUS - 1
    return (frame.command, *(None,) * skipped, *state.seen)[:COUNTER_HISTORY]


def _next(command: Command | None) -> Verdict:
    """The verdict of an intact frame with the next counter."""
    return Verdict.OUT_OF_RANGE if command is None else Verdict.ACCEPTED


def _trust(untrusted: bool, window: tuple[bool, ...], *, conflict: bool) -> bool:
    if conflict or sum(window) >= COUNTER_MISS_LIMIT:
        return True
    full_and_clean = len(window) == COUNTER_WINDOW and not any(window)
    return untrusted and not full_and_clean


def _with(state: MessageState, *, lost: int, last_at: float | None = None) -> MessageState:
    return MessageState(
        state.counter,
        state.seen,
        state.last_at if last_at is None else last_at,
        lost,
        state.window,
        state.untrusted,
    )


# --- ControlCommand's requests -------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class EdgeState:
    """The last accepted ControlCommand, when it arrived, and since when frames arrive again."""

    previous: ControlCommand | None = None
    previous_at: float | None = None
    back_at: float = 0.0

    def __init__(
        self,
        previous: ControlCommand | None = None,
        previous_at: float | None = None,
        back_at: float = 0.0,
    ) -> None:
        object.__setattr__(self, "previous", previous)
        object.__setattr__(self, "previous_at", previous_at)
        object.__setattr__(self, "back_at", back_at)


slot_init(EdgeState)


def edges_step(
    state: EdgeState, command: ControlCommand, arrived_at: float, gap_s: float
) -> tuple[EdgeState, CommandEdges]:
    """The edges an accepted ControlCommand makes against the one before it. A frame after a gap
    longer than `gap_s` has none to compare with; a re-enable counts only once frames have been
    arriving again for `gap_s` (a burst of queued frames is no request)."""
    recent = state.previous_at is not None and arrived_at - state.previous_at <= gap_s
    back_at = state.back_at if recent else arrived_at
    edges = command_edges(state.previous if recent else None, command)
    settled = arrived_at - back_at >= gap_s
    new_state = EdgeState(command, arrived_at, back_at)
    return new_state, CommandEdges(edges.re_enable and settled, edges.remote_stop)


def edges_forgotten(state: EdgeState) -> EdgeState:
    """A ControlCommand frame refused (or not verified): no previous frame to compare with."""
    return EdgeState(back_at=state.back_at)


@dataclass(frozen=True, slots=True)
class StopRequests:
    """Remote stop requests that arrived (`count`), and the newest intact frame asking for one."""

    count: int = 0
    seen_at: float | None = None

    def __init__(self, count: int = 0, seen_at: float | None = None) -> None:
        object.__setattr__(self, "count", count)
        object.__setattr__(self, "seen_at", seen_at)


slot_init(StopRequests)


def stop_request_step(
    state: StopRequests, command: Command | None, arrived_at: float, gap_s: float
) -> StopRequests:
    """A remote stop in an intact (with authentication, verified) ControlCommand frame arrives
    whatever its counter or the id's trust: the filters exist so that bad input cannot *move*
    the robot, and a stop only makes it safer. It arrives when no intact frame asked for one
    within `gap_s` before it; a request held by every frame is one arrival."""
    if not isinstance(command, ControlCommand) or not command.remote_stop:
        return state
    fresh = state.seen_at is None or arrived_at - state.seen_at > gap_s
    return StopRequests(state.count + int(fresh), arrived_at)
