"""A child process's bywire with one more CAN command that the controller obeys: a horn.

`python -m tests.horn_row` adds the horn the way a maintainer adds a command, in the three places
that take it and nowhere else, before anything else of bywire is imported: its message in the
DBC (the packaged `albert.dbc` with one more message, loaded strictly as the codec loads its
own), its class and row in `bywire.command_table` (a `Use.REQUEST` that moves nothing), and its
rule, a line task in `bywire.task_table` that sounds the horn while the decision passes the
request on. Everything else derives from the rows: the codec, the receive checks, the robot
file's timeout key, the decision's slots, trust, and what the simulated computer sends. It then
drives the simulated robot and the configuration loader and prints what it saw as JSON, for
`tests/test_command_table.py` to judge: nothing here asserts.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import re
import sys
from collections.abc import Callable
from functools import cache, partial
from pathlib import Path
from typing import Any, cast

from cantools.database.can import Database

PACKAGED_DBC = Path(__file__).resolve().parent.parent / "src" / "bywire" / "protocol" / "albert.dbc"
HORN_ID = 1 + max(  # the next free command id, after those of the packaged DBC
    int(match) for match in re.findall(r"^BO_ (\d+) \w+Command:", PACKAGED_DBC.read_text(), re.M)
)
HORN_MESSAGE = f"""BO_ {HORN_ID} HornCommand: 3 HLC
 SG_ sound : 0|1@1+ (1,0) [0|1] "" BYWIRE
 SG_ counter : 8|4@1+ (1,0) [0|15] "" BYWIRE
 SG_ crc : 16|8@1+ (1,0) [0|255] "" BYWIRE

"""
HORN_PERIOD = f'BA_ "GenMsgCycleTime" BO_ {HORN_ID} 20;\n'
MESSAGE_BEFORE = "BO_ 512 ModeReport"
PERIOD_BEFORE = 'BA_ "GenMsgCycleTime" BO_ 512 20;'

HORN_CLASS = '''

@dataclass(frozen=True, slots=True)
class HornCommand(Command):
    """The horn: it sounds while the computer asks."""

    sound: bool
    counter: int
'''
HORN_ROW = (
    '    CommandSpec(HornCommand, "horn", HornCommand(sound=False, counter=0), Use.REQUEST,'
    " moves_the_robot=False),\n"
)
CLASS_BEFORE = "\n\n# The rows are in the order"
ROW_BEFORE = ")\nCOMMAND_TYPES"

HORN_IMPORT = "from bywire.command_table import HornCommand\n"
HORN_FUNCTION = '''

def sound_horn(target: TaskTarget, outputs: ControlOutputs, _now: float) -> None:
    """The horn sounds while the decision passes its command's request on."""
    horn = outputs.request(HornCommand)
    target.actuators.write_lines("horn", {"horn": horn is not None and horn.sound})
'''
HORN_TASK = '    TaskSpec("horn", 50.0, 0.002, sound_horn, lines=("horn",)),\n'
IMPORT_BEFORE = "from bywire.control.controller import ControlOutputs"
FUNCTION_BEFORE = "\n\ndef send_reports("
TASK_BEFORE = '    TaskSpec("can_tx"'


def _patched(name: str, edits: list[tuple[str, str]]) -> None:
    """Module `name` from its own source with each text inserted before its marker."""
    spec = importlib.util.find_spec(name)
    if spec is None or spec.origin is None:
        raise SystemExit(f"tests/horn_row.py: {name} has no source file")
    text = Path(spec.origin).read_text()
    for marker, inserted in edits:
        if marker not in text:
            raise SystemExit(f"tests/horn_row.py: {name}'s layout changed ({marker!r}); update me")
        text = text.replace(marker, inserted + marker, 1)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    exec(compile(text, spec.origin, "exec"), module.__dict__)


def install_horn() -> None:
    """The horn's DBC message, command row and task, before the rest of bywire is imported."""
    _patched("bywire.command_table", [(CLASS_BEFORE, HORN_CLASS), (ROW_BEFORE, HORN_ROW)])
    _patched(
        "bywire.task_table",
        [(IMPORT_BEFORE, HORN_IMPORT), (FUNCTION_BEFORE, HORN_FUNCTION), (TASK_BEFORE, HORN_TASK)],
    )
    from bywire.protocol import dbc  # noqa: PLC0415

    @cache
    def database_with_horn() -> Database:
        import cantools  # noqa: PLC0415

        packaged = Path(dbc.__file__).with_name(dbc.DBC_RESOURCE).read_text(encoding="utf-8")
        if MESSAGE_BEFORE not in packaged or PERIOD_BEFORE not in packaged:
            raise SystemExit("tests/horn_row.py: albert.dbc's layout changed; update me")
        text = packaged.replace(MESSAGE_BEFORE, HORN_MESSAGE + MESSAGE_BEFORE, 1)
        text = text.replace(PERIOD_BEFORE, HORN_PERIOD + PERIOD_BEFORE, 1)
        loaded = dbc._as_can_database(
            cantools.database.load_string(text, "dbc", strict=True), "albert.dbc with a horn"
        )
        for message in loaded.messages:
            if message.name.endswith("Command"):
                dbc._check_protection_layout(message)
        return loaded

    dbc.database = database_with_horn


def observe() -> dict[str, object]:
    """What the horn did on the simulated robot and in the loader."""
    from bywire.command_table import COMMAND_TYPES, command_row  # noqa: PLC0415
    from bywire.config import parse_config  # noqa: PLC0415
    from bywire.error_flags import ErrorFlag  # noqa: PLC0415
    from bywire.errors import ConfigError  # noqa: PLC0415
    from bywire.hal.simulated.hlc import Corruption  # noqa: PLC0415
    from bywire.model import ControlMode, Gear  # noqa: PLC0415
    from bywire.protocol import dbc  # noqa: PLC0415
    from bywire.runtime.settings import RuntimeConfig  # noqa: PLC0415
    from tests.system.harness import Robot  # noqa: PLC0415

    horn_kind = command_row_kind("HornCommand", COMMAND_TYPES)
    robot = Robot.build()
    world, runtime = robot.world, robot.runtime
    telemetry = tap_telemetry(runtime)
    hlc, rc = world.hlc, world.rc

    def horn(sound: bool) -> None:
        hlc.set_command(horn_kind(sound=sound, counter=0))

    robot.at(0.0, lambda: hlc.set_movement(0.0, 0.0, 0.3, Gear.FORWARD))
    robot.arm_rc()
    robot.at(0.3, lambda: rc.set_mode(ControlMode.CAN))
    robot.at(0.5, lambda: hlc.set_movement(0.0, 0.0, 0.0, Gear.FORWARD))
    robot.at(0.6, lambda: horn(True))
    robot.at(1.0, lambda: hlc.corrupt_next(15, Corruption.BAD_CRC, horn_kind))  # 300 ms lost
    # A second sender on the horn's id asks for the horn the computer no longer asks for.
    robot.at(1.95, lambda: horn(False))
    robot.at(
        2.0,
        lambda: world.impostors[horn_kind].start(
            25, kind=horn_kind, asks=horn_kind(sound=True, counter=0)
        ),
    )
    robot.at(2.6, lambda: horn(True))  # the impostor gone: trust comes back with a window
    robot.at(3.2, lambda: rc.set_mode(ControlMode.RC))  # the horn is CAN mode's alone
    flags: dict[str, list[str]] = {}
    modes: dict[str, str] = {}
    untrusted: dict[str, bool] = {}

    def sample(label: str) -> None:
        outputs = runtime.outputs
        if outputs is not None:
            modes[label] = outputs.mode.name
            flags[label] = sorted(str(flag.name) for flag in ErrorFlag(outputs.error_flags))
        untrusted[label] = horn_kind in runtime.can.untrusted_kinds

    for label in ("0.9", "1.3", "2.3"):
        robot.at(float(label), partial(sample, label))
    robot.run(3.6)
    line = world.gpio["horn"]
    sounding = {f"{t:.2f}": line.level_at(t) for t in (0.55, 0.65, 0.9, 1.05, 1.3, 1.9)}
    during_impostor = [line.level_at(2.05 + 0.01 * n) for n in range(45)]
    horn_frames = [
        frame.time_s
        for frame in world.bus.log
        if frame.arbitration_id == dbc.frame_id(horn_kind) and frame.sender == "hlc"
    ]

    robot_file = "[timeouts.can_message_timeout_s]\nHornCommand = 0.25\n"
    configured = RuntimeConfig.from_robot(parse_config(robot_file))
    refusals = {}
    try:
        parse_config("[timeouts.can_message_timeout_s]\nHornCommand = 0.03\n")
    except ConfigError as error:
        refusals["too_short"] = str(error)
    return {
        "row": [command_row(horn_kind).name, command_row(horn_kind).slot],
        "sounding_at": sounding,
        "sounding_while_untrusted": during_impostor,
        "sounding_after_untrusted": line.level_at(3.15),
        "sounding_in_rc_mode": line.level_at(3.5),
        "sounding_at_end": line.level,
        "modes": modes,
        "flags": flags,
        "untrusted": untrusted,
        "causes": sorted(cause.name for cause in runtime.outputs.causes)
        if runtime.outputs
        else None,
        "horn_frames_first_second": sum(1 for t in horn_frames if t < 1.0),
        "hlc_refused": dict(hlc.refused),
        "hlc_mailboxes": hlc._port._tx_mailboxes,
        "enabled_while_untrusted": robot.level("motors_enable", 2.3),
        "configured_timeout_s": configured.control.command_timeout_s(horn_kind),
        "rx_check_timeout_s": [c.timeout_s for c in configured.rx_checks if c.kind is horn_kind],
        "refusals": refusals,
        **telemetry(),
        "frame_cli": frame_cli(),
    }


def tap_telemetry(runtime: Any) -> Callable[[], dict[str, object]]:
    """The telemetry feed's captures of the run, and then what its state messages said."""
    from jsonschema import Draft202012Validator  # noqa: PLC0415

    from bywire.telemetry.capture import Capture, StateCapture, TelemetryTap  # noqa: PLC0415
    from bywire.telemetry.messages import message  # noqa: PLC0415
    from bywire.telemetry.outbox import Outbox  # noqa: PLC0415
    from bywire.telemetry.schemas import SCHEMAS, STATE_TOPIC  # noqa: PLC0415

    outbox: Outbox[Capture] = Outbox(1_000_000)
    TelemetryTap(runtime, outbox).attach()

    def seen() -> dict[str, object]:
        states = [message(c)[1] for c in outbox.take(0.0) if isinstance(c, StateCapture)]
        validator = Draft202012Validator(SCHEMAS[STATE_TOPIC])
        return {
            "telemetry_state_errors": sorted(
                {error.message for state in states for error in validator.iter_errors(state)}
            ),
            "telemetry_horn_age_s": {
                label: next(
                    s["inputs"].get("can_horn_age_s", "missing")
                    for s in states
                    if s["time_s"] >= at_s
                )
                for label, at_s in (("0.90", 0.9),)
            },
        }

    return seen


def frame_cli() -> object:
    """`bywire frame horn --sound`: the frames it prints, decoded (its options from the fields)."""
    import contextlib  # noqa: PLC0415
    import io  # noqa: PLC0415

    from bywire.cli.main import main  # noqa: PLC0415
    from bywire.protocol import dbc  # noqa: PLC0415

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        status = main(["frame", "horn", "--sound", "--counter", "15", "--count", "2"])
    decoded = []
    for line in out.getvalue().split():
        frame_id, _, data = line.partition("#")
        command = dbc.decode_intact(int(frame_id, 16), bytes.fromhex(data))
        decoded.append([type(command).__name__, *dataclasses.astuple(cast(Any, command))])
    return {"status": status, "frames": decoded}


def command_row_kind(name: str, kinds: tuple[type, ...]) -> type:
    """The command type named `name` among the table's."""
    return next(kind for kind in kinds if kind.__name__ == name)


if __name__ == "__main__":
    install_horn()
    print(json.dumps(observe()))
