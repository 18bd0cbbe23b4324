"""`bywire verify` on robot files nobody wrote: hypothesis draws legal ones, each is verified.

Issue 30 asks for `bywire verify --budget 2000` clean on albert and on a hypothesis-drawn set of
legal robot files. This draws `--robots` files with the strategy the tests use
(`tests/sim/verify/robot_files.py`: every number moved within what the loader allows and a real
robot could use), keeps those the loader takes (a file it refuses names the key or the deadline it
breaks: `tests/config` holds that), writes each to `--out`, and runs `bywire verify --config FILE
--budget N --seed S --json` on it, one after the other, each on every core. The budget is shared:
`--budget 2000 --robots 20` gives each file 100 campaigns. Exit 1 if any run found a violation;
its file and the failure's scenario are in `--out`.

    python bench/verify_drawn.py --robots 20 --budget 2000 --out /tmp/drawn
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # the strategy lives with the tests

from hypothesis import HealthCheck, Phase, given, settings  # noqa: E402
from hypothesis import seed as hypothesis_seed  # noqa: E402
from tests.sim.verify.robot_files import robot_files  # noqa: E402

from bywire.config import parse_config  # noqa: E402
from bywire.errors import ConfigError  # noqa: E402


def draw_files(count: int, seed: int) -> list[str]:
    """`count` drawn robot files that the loader takes, the same ones for the same seed."""
    kept: list[str] = []

    @settings(
        max_examples=count * 50,
        database=None,
        phases=[Phase.generate],
        suppress_health_check=list(HealthCheck),
        deadline=None,
    )
    @hypothesis_seed(seed)
    @given(text=robot_files())
    def collect(text: str) -> None:
        if len(kept) >= count:
            return
        try:
            parse_config(text, "<drawn robot file>")
        except ConfigError:
            return
        kept.append(text)

    collect()
    return kept


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--robots", type=int, default=20, help="robot files to draw (20)")
    parser.add_argument("--budget", type=int, default=2000, help="campaigns in all (2000)")
    parser.add_argument("--seed", type=int, default=0, help="drawing and verify seed (0)")
    parser.add_argument("--out", type=Path, default=Path("verify-drawn"), help="output folder")
    options = parser.parse_args()
    files = draw_files(options.robots, options.seed)
    if len(files) < options.robots:
        print(f"only {len(files)} legal files drawn of {options.robots}", file=sys.stderr)
    options.out.mkdir(parents=True, exist_ok=True)
    each = max(1, options.budget // max(1, len(files)))
    failures = campaigns = 0
    checks = 0
    started = time.monotonic()
    for number, text in enumerate(files, 1):
        path = options.out / f"robot-{number:02d}.toml"
        path.write_text(text)
        command = [
            sys.executable, "-m", "bywire", "verify", "--config", str(path),
            "--budget", str(each), "--seed", str(options.seed), "--json",
            "--out", str(options.out / f"failures-{number:02d}"),
        ]  # fmt: skip
        done = subprocess.run(command, capture_output=True, text=True, check=False)
        if done.returncode == 2:
            print(f"{path}: refused: {done.stderr.strip()}", file=sys.stderr)
            failures += 1
            continue
        summary = json.loads(done.stdout)
        found = sum(summary["violations"].values())
        campaigns += summary["campaigns"]
        checks += summary["invariant_checks"]
        failures += done.returncode != 0
        verdict = (
            "clean" if done.returncode == 0 else f"{found} violations (exit {done.returncode})"
        )
        print(
            f"[{number}/{len(files)}] {path}: {summary['campaigns']} campaigns, {verdict}"
            f" ({time.monotonic() - started:.0f} s)",
            flush=True,
        )
    print(
        f"{len(files)} drawn robot files, {campaigns} campaigns, {checks} invariant checks,"
        f" {failures} files with a finding, {time.monotonic() - started:.0f} s"
    )
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
