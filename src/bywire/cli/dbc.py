"""`bywire dbc`: show the CAN database's messages and signals, generate C code from it, or hand
the packaged albert.dbc to other tools (`path`, `export`)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from importlib import resources
from pathlib import Path
from typing import Any

from cantools.database.can import Database, Message, Signal
from cantools.database.can.c_source import generate

from bywire.errors import BywireError
from bywire.protocol import protection_c, secoc_c
from bywire.protocol.dbc import (
    DBC_RESOURCE,
    DbcError,
    database,
    load_database,
    load_user_database,
)


class OutputError(BywireError, OSError):
    """The generated files cannot be written where the user asked."""


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the `show`, `codegen`, `path` and `export` sub-commands."""
    commands = parser.add_subparsers(dest="dbc_command", metavar="ACTION", required=True)
    show = commands.add_parser("show", help="list messages and signals")
    codegen = commands.add_parser(
        "codegen", help="write cantools-generated C (.h and .c) and the CRC-8/counter helper"
    )
    codegen.add_argument("outdir", type=Path, metavar="OUTDIR", help="created if missing")
    codegen.add_argument(
        "--name", type=_c_identifier, default="albert", help="C prefix and file name (albert)"
    )
    for sub in (show, codegen):
        sub.add_argument("--dbc", type=Path, metavar="FILE", help="DBC file (packaged albert.dbc)")
    commands.add_parser(
        "path",
        help="print the path of the packaged albert.dbc (for cantools, SavvyCAN, Foxglove …)",
    )
    export = commands.add_parser("export", help="write the packaged albert.dbc to FILE")
    export.add_argument("file", type=Path, metavar="FILE", help="where to write it ('-': stdout)")
    export.add_argument("--force", action="store_true", help="overwrite FILE if it exists")


def load_user_dbc(path: Path, command: str) -> Database:
    """The user's DBC; a note on stderr when it only loads without cantools' strict checks."""
    loaded, lenient_reason = load_user_database(path)
    if lenient_reason is not None:
        print(
            f"bywire {command}: note: {path.name} fails cantools' strict checks"
            f" ({lenient_reason}); loaded without them",
            file=sys.stderr,
        )
    return loaded


def load_codegen_dbc(path: Path) -> Database:
    """The user's DBC for code generation: strictly, or DbcError naming the problem. Lenient
    loading is for the tools that only read a file; C generated from a signal that does not fit
    its message writes past the frame's buffer (cantools' own generator refuses such a file
    unless told `--no-strict`)."""
    try:
        return load_database(path)
    except DbcError as error:
        raise DbcError(
            f"{error}: C code is generated only from a DBC that passes cantools' strict checks"
            " (fix the file; `bywire dbc show --dbc FILE` lists it as it loads)"
        ) from None


def packaged_dbc_path() -> Path:
    """The packaged albert.dbc as a file on disk (an installed wheel holds it as one; a
    zipped package would need `dbc export`)."""
    resource = resources.files("bywire.protocol").joinpath(DBC_RESOURCE)
    path = Path(str(resource))
    if not path.is_file():
        raise OutputError(
            f"the packaged {DBC_RESOURCE} is not a file here: use `bywire dbc export FILE`"
        )
    return path


def export_dbc(target: Path, *, force: bool) -> None:
    """Write the packaged albert.dbc, byte for byte, to `target` ('-': stdout)."""
    data = resources.files("bywire.protocol").joinpath(DBC_RESOURCE).read_bytes()
    if str(target) == "-":
        sys.stdout.buffer.write(data)
        return
    if target.exists() and not force:
        raise OutputError(f"{target} exists: add --force to overwrite it, or choose another file")
    try:
        target.write_bytes(data)
    except OSError as error:
        raise OutputError(f"cannot write {target}: {error.strerror or error}") from error
    print(f"{target} ({len(data)} bytes, albert.dbc)")


def _c_identifier(text: str) -> str:
    if not (text.isascii() and text.isidentifier()):
        raise argparse.ArgumentTypeError(f"{text!r} is not a C identifier")
    return text


def run(args: argparse.Namespace) -> int:
    """Run `show`, `codegen`, `path` or `export`; an unreadable DBC raises DbcError (one line,
    exit status 2)."""
    if args.dbc_command == "path":
        print(packaged_dbc_path())
        return 0
    if args.dbc_command == "export":
        export_dbc(args.file, force=args.force)
        return 0
    if args.dbc is None:
        loaded = database()
    elif args.dbc_command == "codegen":
        loaded = load_codegen_dbc(args.dbc)
    else:
        loaded = load_user_dbc(args.dbc, "dbc")
    if args.dbc_command == "show":
        print("\n".join(describe(loaded)))
    else:
        for path in write_c_sources(loaded, args.outdir, args.name):
            print(path)
    return 0


# --- show -------------------------------------------------------------------------------------

_NAME_WIDTH = 20


def _signal_header(width: int) -> str:
    return (
        f"    {'signal':<{width}} {'start':>5} {'len':>3}  {'type':<8} {'scale':>8} {'offset':>6}"
        f"  {'unit':<8} {'range':<24} values"
    )


def describe(loaded: Database) -> list[str]:
    """Plain-text lines: each message (by id) with its signals."""
    lines = [_bus_line(loaded)]
    for message in sorted(loaded.messages, key=lambda message: message.frame_id):
        lines += ["", *_message_lines(message)]
    return lines


def _bus_line(loaded: Database) -> str:
    bus = loaded.buses[0] if loaded.buses else None
    rate = f", {bus.baudrate // 1000} kbit/s" if bus is not None and bus.baudrate else ""
    return f"{len(loaded.messages)} messages{rate}"


def _message_lines(message: Message) -> list[str]:
    senders = ",".join(message.senders) or "-"
    period = f"{message.cycle_time} ms" if message.cycle_time else "-"
    head = f"0x{message.frame_id:03X}  {message.name}  sender {senders}  DLC {message.length}"
    lines = [f"{head}  period {period}", f"    {message.comment or '(no comment)'}"]
    rows = _tree_rows(message, message.signal_tree, 0)
    width = max([_NAME_WIDTH, *(len(row[0]) for row in rows if isinstance(row, tuple))])
    body = [row if isinstance(row, str) else _signal_line(*row, width=width) for row in rows]
    return [*lines, _signal_header(width), *body]


# A signal row before alignment: (indented name, signal, suffix); or a finished "when" line.
_Row = tuple[str, Signal, str] | str


def _tree_rows(message: Message, tree: Sequence[Any], depth: int) -> list[_Row]:
    """Signals in cantools' signal tree order; a multiplexer's signals per mux value, indented.

    Signals of different mux values share bits; grouped under ``when MUX = value`` (as cantools'
    own ``dump`` groups them) they no longer look like overlapping signals.
    """
    indent = "  " * depth
    lines: list[_Row] = []
    for node in tree:
        if isinstance(node, str):
            lines.append((indent + node, message.get_signal_by_name(node), ""))
            continue
        for mux_name, branches in node.items():
            multiplexer = message.get_signal_by_name(mux_name)
            lines.append((indent + mux_name, multiplexer, "(multiplexer)"))
            for value, subtree in sorted(branches.items()):
                choice = (multiplexer.choices or {}).get(value)
                label = f"{value} ({choice})" if choice is not None else str(value)
                lines.append(f"    {indent}when {mux_name} = {label}:")
                lines += _tree_rows(message, subtree, depth + 1)
    return lines


def _signal_line(name: str, signal: Signal, suffix: str, *, width: int) -> str:
    kind = "float" if signal.is_float else "signed" if signal.is_signed else "unsigned"
    if signal.byte_order == "big_endian":
        kind += " BE"
    limits = "-"
    if signal.minimum is not None or signal.maximum is not None:
        limits = f"[{_number(signal.minimum)}|{_number(signal.maximum)}]"
    choices = " ".join(f"{value}={text}" for value, text in (signal.choices or {}).items())
    return (
        f"    {name:<{width}} {signal.start:>5} {signal.length:>3}  {kind:<8}"
        f" {signal.scale:>8} {signal.offset:>6}  {signal.unit or '-':<8} {limits:<24}"
        f" {' '.join(part for part in (suffix, choices) if part)}"
    ).rstrip()


def _number(value: float | None) -> str:
    return "-" if value is None else str(value)


# --- codegen ----------------------------------------------------------------------------------


def write_c_sources(loaded: Database, outdir: Path, name: str) -> list[Path]:
    """Write ``<name>.h`` and ``<name>.c`` (cantools' C generator) into outdir, and beside them
    ``<name>_protection.h``/``.c`` (the commands' CRC-8 and rolling counter) and
    ``<name>_secoc.h``/``.c`` (their SecOC signing: AES-128, CMAC); their paths.

    The encoders round to nearest (``use_round``; link with -lm) instead of cantools' default
    truncation, which would turn 0.1234 into 1233 steps where the Python codec sends 1234.
    """
    header, source, _fuzzer, _makefile = generate(
        loaded, name, f"{name}.h", f"{name}.c", f"{name}_fuzzer.c", use_round=True
    )
    texts = {
        f"{name}.h": header,
        f"{name}.c": source,
        f"{name}_protection.h": protection_c.header(name),
        f"{name}_protection.c": protection_c.source(name),
        f"{name}_secoc.h": secoc_c.header(name),
        f"{name}_secoc.c": secoc_c.source(name),
    }
    paths = [outdir / file_name for file_name in texts]
    try:
        outdir.mkdir(parents=True, exist_ok=True)
        for path, text in zip(paths, texts.values(), strict=True):
            path.write_text(text, encoding="utf-8")
    except OSError as error:
        raise OutputError(f"cannot write into {outdir}: {error}") from error
    return paths
