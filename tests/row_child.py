"""What a child process that adds a table row from source saw (`tests/beeper_row.py`,
`tests/horn_row.py`): the child prints JSON, the tests judge it."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def observed(module: str) -> dict[str, object]:
    """Runs `python -m <module>` from the clone with its sources first on the path, and returns
    the JSON it printed (a child that fails fails the caller, with its stderr)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(ROOT / "src")])}
    done = subprocess.run(
        [sys.executable, "-m", module],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    seen: dict[str, object] = json.loads(done.stdout)
    return seen
