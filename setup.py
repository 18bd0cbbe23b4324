"""The opt-in compiled build (issue 43): `BYWIRE_COMPILE=1 pip install .` compiles the modules
below with mypyc; without it this file adds nothing and the package is pure Python.

Compiled: the controller, the runtime, the simulated hardware, the codecs, the configuration,
the simulator with the verifier and its oracle, security, and the small top-level modules they
import. Left pure (`LEFT_PURE`): the shells around them (commands, dashboards, telemetry, ROS,
teleop, the RC tool, monitor, replay, log files, the Linux and tape backends, bench) and
`bywire/__init__.py`, which says which build runs. Options: `MYPYC_OPT_LEVEL` (mypyc's default 3),
`MYPYC_DEBUG_LEVEL`.
"""

from __future__ import annotations

import hashlib
import json
import os
from importlib.machinery import EXTENSION_SUFFIXES
from pathlib import Path

from setuptools import setup
from setuptools.command.build_ext import build_ext

SRC = Path(__file__).parent / "src"

COMPILED = (
    "bywire/control/*.py",
    "bywire/runtime/*.py",
    "bywire/hal/simulated/*.py",
    "bywire/hal/hardware.py",
    "bywire/hal/ports.py",
    "bywire/protocol/*.py",
    "bywire/config/*.py",
    "bywire/sim/*.py",
    "bywire/sim/verify/*.py",
    "bywire/sim/verify/oracle/*.py",
    "bywire/sim/verify/oracle/checks/*.py",
    "bywire/security/*.py",
    "bywire/background.py",
    "bywire/can_frame.py",
    "bywire/command_table.py",
    "bywire/errors.py",
    "bywire/error_flags.py",
    "bywire/loopback.py",
    "bywire/model.py",
    "bywire/priority.py",
    "bywire/task_table.py",
    "bywire/textfile.py",
    "bywire/atomic_file.py",
)

LEFT_PURE = {
    # the exceptions derive from ValueError and OSError, which a native class cannot; raised,
    # never on a hot path
    "bywire/errors.py",
    # `@value` is typing.dataclass_transform's, which sets an attribute on the function it
    # marks: a compiled function has none to set ("the decorator cannot be applied", issue 43),
    # and mypy knows the mark only on the def itself (a run-time stand-in under `if
    # TYPE_CHECKING:`/`else:` is code mypyc calls unreachable and refuses to run). Nothing is
    # lost: it runs when a class is made, and the `__init__` it makes is exec'd Python anyway
    "bywire/control/values.py",
    # matplotlib drawing of a finished run: not on any path a run or a campaign takes
    "bywire/sim/plot.py",
    # `verify --cluster`'s Dask client and worker plugin: an optional extra (`bywire[cluster]`)
    # that the build does not install, so mypyc could not type-check them against it; they hand
    # batches to compiled campaigns and carry their results (I/O, not computation)
    "bywire/sim/verify/cluster.py",
    "bywire/sim/verify/cluster_worker.py",
}


def compiled_modules() -> list[str]:
    """Every source file of the compiled build, relative to src/, sorted."""
    found = {str(path.relative_to(SRC)) for pattern in COMPILED for path in SRC.glob(pattern)}
    return sorted(found - LEFT_PURE)


SOURCE_HASHES: dict[str, str] = {}
"""Each compiled module's source SHA-256, taken when mypyc reads it."""


def extensions() -> list[object]:
    if os.environ.get("BYWIRE_COMPILE", "") != "1" or os.environ.get("BYWIRE_NOT_BUILDING"):
        return []
    from mypyc.build import mypycify  # noqa: PLC0415 (only the compiled build needs it)

    # The sources as mypyc reads them now: one edited during the build is then stale, as it is.
    SOURCE_HASHES.update(
        (module, hashlib.sha256((SRC / module).read_bytes()).hexdigest())
        for module in compiled_modules()
    )
    # Paths under src/ (no __init__.py there): mypyc names src/bywire/model.py bywire.model.
    return list(
        mypycify(
            [f"src/{module}" for module in compiled_modules()],
            opt_level=os.environ.get("MYPYC_OPT_LEVEL", "3"),
            debug_level=os.environ.get("MYPYC_DEBUG_LEVEL", "1"),
            multi_file=True,
        )
    )


class BuildWithRecord(build_ext):
    """setuptools' build_ext, then `bywire/_compiled.json` beside the compiled modules: the
    compiler, its level and each compiled source's SHA-256, which `bywire.build` checks so that
    a compiled module never silently runs when its source has changed since."""

    def run(self) -> None:
        if self.extensions:
            self._remove_others()
        super().run()
        if not self.extensions:
            return
        from mypy.version import __version__ as mypyc_version  # noqa: PLC0415

        package_dir = Path(self.get_ext_fullpath("bywire.model")).parent
        record = {
            "mypyc": mypyc_version,
            "opt_level": os.environ.get("MYPYC_OPT_LEVEL", "3"),
            "sources": SOURCE_HASHES,
        }
        (package_dir / "_compiled.json").write_text(json.dumps(record, indent=1) + "\n")

    def _remove_others(self) -> None:
        """Compiled modules an earlier build left where this one builds (build/lib, or src/ in
        place) that this one does not compile: they would be shipped and imported instead of
        their source."""
        package_dir = Path(self.get_ext_fullpath("bywire.model")).parent
        built = {Path(self.get_ext_fullpath(extension.name)) for extension in self.extensions}
        for path in package_dir.rglob("*"):
            if path.name.endswith(tuple(EXTENSION_SUFFIXES)) and path not in built:
                path.unlink()


if __name__ == "__main__":  # setuptools runs it so; bench/compiled_value_eq.py reads the lists
    setup(ext_modules=extensions(), cmdclass={"build_ext": BuildWithRecord})
