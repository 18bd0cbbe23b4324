"""Hypothesis strategies that damage a valid TOML file the way people and disks do.

Two kinds, mixed: a parsed document changed and written back (a value of another type, out of
range or not finite, an integer too big for a float, a table where a number goes and the other way
round, a key dropped or one added, anywhere in the tree), and the file's bytes changed (cut short,
bytes replaced or inserted, invalid UTF-8 among them, a line doubled). Loaders under test must
take each one or refuse it in one line; none may crash or hang.
"""

from __future__ import annotations

import contextlib
import datetime
import io
import math
import tomllib
from typing import Any

import tomli_w
from hypothesis import strategies as st

from bywire.cli.main import main

Path = tuple[str | int, ...]

NASTY_FLOATS = (math.nan, math.inf, -math.inf, 1e300, -1e300, 5e-324, -0.0, 1e-300)
NASTY_INTS = (2**63 - 1, -(2**63), 2**64, 10**400, -(10**30), 0, -1, 1 << 53)


def scalars() -> st.SearchStrategy[Any]:
    """TOML values, weighted towards the ones that break code: not finite, huge, wrong type."""
    return st.one_of(
        st.sampled_from(NASTY_FLOATS),
        st.sampled_from(NASTY_INTS),
        st.integers(-100_000, 100_000),
        st.floats(allow_nan=True, allow_infinity=True),
        st.booleans(),
        st.text(max_size=20),
        st.sampled_from(["", " ", "stop", "rc", "can", "forward", "can_flood", "\u0661", "0-9"]),
        st.datetimes(max_value=datetime.datetime(9999, 1, 1)),
        st.dates(),
        st.times(),
    )


def values() -> st.SearchStrategy[Any]:
    """A scalar, an array or a table, nested a little."""
    return st.recursive(
        scalars(),
        lambda inner: st.one_of(
            st.lists(inner, max_size=4),
            st.dictionaries(st.text(min_size=1, max_size=8), inner, max_size=3),
        ),
        max_leaves=6,
    )


def _paths(node: Any, prefix: Path = ()) -> list[Path]:
    """Every place in the document that holds a value, the root's children first."""
    found: list[Path] = []
    if isinstance(node, dict):
        for key, child in node.items():
            found.append((*prefix, key))
            found += _paths(child, (*prefix, key))
    elif isinstance(node, list):
        for index, child in enumerate(node):
            found.append((*prefix, index))
            found += _paths(child, (*prefix, index))
    return found


def _parent(document: Any, path: Path) -> Any:
    node = document
    for part in path[:-1]:
        node = node[part]
    return node


@st.composite
def _document_mutation(draw: st.DrawFn, document: dict[str, Any]) -> None:
    """One change, in place, somewhere in the tree."""
    paths = _paths(document)
    action = draw(st.sampled_from(["replace", "replace", "replace", "drop", "add", "nest"]))
    if not paths or action == "add":
        target = document
        containers = [p for p in paths if isinstance(_get(document, p), dict)]
        inner = draw(st.booleans())
        if containers and inner:
            target = _get(document, draw(st.sampled_from(containers)))
        target[draw(st.text(min_size=1, max_size=12))] = draw(values())
        return
    path = draw(st.sampled_from(paths))
    parent, last = _parent(document, path), path[-1]
    if action == "drop":
        del parent[last]
    elif action == "nest":  # a table or array where a scalar goes, or the other way round
        old = parent[last]
        parent[last] = draw(scalars()) if isinstance(old, dict | list) else {"x": old}
    else:
        parent[last] = draw(values())


def _get(document: Any, path: Path) -> Any:
    node = document
    for part in path:
        node = node[part]
    return node


@st.composite
def mutated_documents(draw: st.DrawFn, text: str) -> bytes:
    """The file `text` parsed, changed one to three times, written back as TOML."""
    document = tomllib.loads(text)
    for _ in range(draw(st.integers(1, 3))):
        draw(_document_mutation(document))
    try:
        return tomli_w.dumps(document).encode()
    except (TypeError, ValueError):  # what TOML cannot hold (a key of every kind is fine)
        return text.encode()


@st.composite
def mutated_bytes(draw: st.DrawFn, text: str) -> bytes:
    """The file's bytes cut, overwritten, inserted into or a line doubled."""
    data = bytearray(text.encode())
    action = draw(st.sampled_from(["cut", "overwrite", "insert", "double"]))
    at = draw(st.integers(0, len(data)))
    if action == "cut":
        return bytes(data[:at])
    if action == "double":
        lines = bytes(data).splitlines(keepends=True)
        index = draw(st.integers(0, max(len(lines) - 1, 0)))
        return b"".join(lines[: index + 1] + lines[index:])
    junk = draw(
        st.one_of(
            st.binary(min_size=1, max_size=8),
            st.sampled_from([b"\xff", b"\xc3", b"\x00", b"=", b"[", b"]]", b'"', b"\n[[x]]\n"]),
            st.sampled_from([b"\nhuge = " + b"9" * 5000 + b"\n", b"\ndeep = " + b"[" * 3000]),
        )
    )
    if action == "overwrite":
        data[at : at + len(junk)] = junk
    else:
        data[at:at] = junk
    return bytes(data)


def mutated_files(text: str) -> st.SearchStrategy[bytes]:
    """A damaged copy of a valid file: mostly changed values, sometimes changed bytes."""
    return st.one_of(
        mutated_documents(text),
        mutated_documents(text),
        mutated_documents(text),
        mutated_bytes(text),
    )


def run_bywire(*argv: str) -> tuple[int, str]:
    """`bywire ARGV` in this process: (exit status, stderr); a traceback fails the caller."""
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        status = main(list(argv))
    return status, err.getvalue()


def assert_refused_in_one_line(command: str, status: int, err: str) -> None:
    """Exit 2 and one line `bywire COMMAND: error: ...` (a robot file with several problems
    lists them on the lines below, each indented, each naming its key)."""
    assert status == 2, err
    first, *rest = err.rstrip("\n").split("\n")
    assert first.startswith(f"bywire {command}: error: "), err
    if rest:
        assert first.endswith("problems:"), err
        assert all(line.startswith("  ") for line in rest), err
