"""The command table: every CAN command message the controller obeys, one row each, with its use.

A row is to a command what a `bywire.task_table` row is to a periodic task: the rest of the
controller derives from it and nothing keeps a second list. A row holds the message's type (a
`bywire.model.Command` named like its DBC message, its fields like its signals), its slot name,
what losing trust in its id does (`moves_the_robot`) and which error flag says so, the frame the
simulated higher-level computer sends until told otherwise (`neutral`), and how the decision uses
it (`use`, a rule the controller applies: `bywire.control.controller`). Derived from the rows:
the codec's command messages (`bywire.protocol.dbc`), the robot file's timeout keys
(`[timeouts.can_message_timeout_s] <Message>`: `timeout_key`) and their receive checks
(`bywire.runtime.rx_checks`), the decision's inputs (`bywire.control.command_slots`), when an
arrival changes the decision, the reader's trust, and what the simulated computer sends and how
many transmit mailboxes it needs.

A new command the controller obeys is its message in the DBC, its class and row here, and the
rule that acts on it: a `Use.REQUEST` row reaches the tasks as `ControlOutputs.request(kind)`
while fresh and trusted, in CAN mode, so its rule is a task (`bywire.task_table`).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from bywire.error_flags import ErrorFlag
from bywire.model import LIGHTS_OFF, Command, ControlCommand, Gear, LightsCommand, MovementCommand


class Use(enum.Enum):
    """How the decision uses a command message (each rule is the controller's)."""

    STOP_AND_RE_ENABLE = "remote stop (REMOTE_STOP) and the re-enable edge that re-arms"
    SET_POINTS = "CAN mode's steering, throttle, brake and gear; stale or missing: CAN_LOST"
    LIGHT_REQUESTS = "CAN mode's light requests; the last trusted one held while untrusted"
    REQUEST = "`ControlOutputs.request`, in CAN mode while fresh and trusted, for a task's rule"


@dataclass(frozen=True, slots=True)
class CommandSpec:
    """One row of the command table: one CAN command message (see the module's text)."""

    kind: type[Command]
    slot: str  # its short name: the decision's and the simulated computer's
    neutral: Command  # what the simulated computer sends until told otherwise
    use: Use
    moves_the_robot: bool = True  # losing trust in its id stops CAN driving (CAN_UNTRUSTED)
    untrusted_flag: ErrorFlag = ErrorFlag.CAN_UNTRUSTED  # up while its id is not trusted

    @property
    def name(self) -> str:
        """The message's DBC name."""
        return self.kind.__name__

    @property
    def timeout_key(self) -> str:
        """The robot-file key of its age limit (else `timeouts.can_command_timeout_s`)."""
        return f"timeouts.can_message_timeout_s.{self.name}"


# The rows are in the order the simulated computer sends them each period.
COMMANDS: tuple[CommandSpec, ...] = (
    CommandSpec(
        ControlCommand,
        "control",
        ControlCommand(remote_stop=False, re_enable=False, counter=0),
        Use.STOP_AND_RE_ENABLE,
    ),
    CommandSpec(
        MovementCommand,
        "movement",
        MovementCommand(0.0, 0.0, 1.0, Gear.NEUTRAL, 0),  # full brake, neutral
        Use.SET_POINTS,
    ),
    CommandSpec(
        LightsCommand,
        "lights",
        LIGHTS_OFF,
        Use.LIGHT_REQUESTS,
        moves_the_robot=False,
        untrusted_flag=ErrorFlag.LIGHTS_UNTRUSTED,
    ),
)
COMMAND_TYPES: tuple[type[Command], ...] = tuple(spec.kind for spec in COMMANDS)
MOVES_NOTHING: frozenset[type[Command]] = frozenset(
    spec.kind for spec in COMMANDS if not spec.moves_the_robot
)
"""Commands that move nothing: a second sender on one of their ids costs that function alone its
requests. Losing trust in any other command, a new one included unless its row says so, stops
CAN driving (CAN_UNTRUSTED): the safe default (hazard row 39)."""
REQUESTS: tuple[CommandSpec, ...] = tuple(spec for spec in COMMANDS if spec.use is Use.REQUEST)
"""The rows the decision passes to the tasks (`Use.REQUEST`)."""
_ROWS = {spec.kind: spec for spec in COMMANDS}


def command_row(kind: type[Command]) -> CommandSpec:
    """The row of the message `kind` (LookupError if the table has none)."""
    try:
        return _ROWS[kind]
    except KeyError:
        raise LookupError(f"no command row for {kind.__name__}") from None
