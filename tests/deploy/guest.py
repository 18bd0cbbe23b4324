"""The deploy tier's typist, inside the fresh Debian: a oneshot service at boot runs one phase of
the plan (tests/deploy/commands.py, as JSON), each line as its user would type it into a shell.

Usage (in the guest): python3 guest.py PLAN.json PHASE TRANSCRIPT.jsonl

Each line runs in bash as `eval` of its text, verbatim, in the directory where that user's last
line ended (so `cd /opt/bywire` holds for the lines after it, across the phases' two boots),
with a login's environment, no terminal and nothing on its standard input. A line that runs
until stopped gets Ctrl-C (SIGINT to its process group) after its `interrupt_s`; any line is
killed after LIMIT_S. The transcript gets a "start" record before each line and an "end" record
(exit status, output, seconds) after it, which the host reads as they come. Standard library
only: this runs on the guest's own Python before anything is installed.
"""

from __future__ import annotations

import json
import os
import pwd
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

STATE = Path("/var/lib/bywire-deploy-tier")
LIMIT_S = 900.0
KILL_AFTER_S = 10.0
MAX_OUTPUT = 200_000
ROOT_PATH = "/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin"
USER_PATH = "/usr/local/bin:/usr/bin:/bin"
RUNUSER = "/usr/sbin/runuser"  # by its path: the line's environment has the user's PATH
# $1: where to start, $2: the line, $3: where to write where it ended
SHELL = 'cd -- "$1" || exit 97\neval "$2"\nstatus=$?\npwd > "$3"\nexit $status\n'


def _environment(user: pwd.struct_passwd, extra: dict[str, str]) -> dict[str, str]:
    return {
        "HOME": user.pw_dir,
        "USER": user.pw_name,
        "LOGNAME": user.pw_name,
        "SHELL": user.pw_shell or "/bin/sh",
        "PATH": ROOT_PATH if user.pw_uid == 0 else USER_PATH,
        "LANG": "C.UTF-8",
        **extra,
    }


def _where(user: pwd.struct_passwd, step: dict[str, Any]) -> tuple[str, Path]:
    """Where the line starts, and the file its shell writes where it ended."""
    ended = STATE / f"cwd-{user.pw_name}"
    if not ended.exists():
        ended.write_text(user.pw_dir, encoding="utf-8")
        os.chown(ended, user.pw_uid, user.pw_gid)
    start = step["cwd"] or ended.read_text(encoding="utf-8").strip() or user.pw_dir
    return start, ended


def _run(step: dict[str, Any], env_all: dict[str, str]) -> tuple[int, str, bool]:
    """Exit status (negative: the signal that ended it), output, whether the tier stopped it."""
    user = pwd.getpwnam(step["user"])
    start, ended = _where(user, step)
    argv = ["bash", "-c", SHELL, "bash", start, step["text"], str(ended)]
    if user.pw_uid != 0:
        argv = [RUNUSER, "-u", user.pw_name, "--", *argv]
    process = subprocess.Popen(
        argv,
        env=_environment(user, {**env_all, **step["env"]}),
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        start_new_session=True,
    )
    interrupt_s = step["interrupt_s"]
    stopped = False
    try:
        output, _ = process.communicate(timeout=interrupt_s if interrupt_s else LIMIT_S)
    except subprocess.TimeoutExpired:
        stopped = True
        os.killpg(process.pid, signal.SIGINT if interrupt_s else signal.SIGKILL)
        try:
            output, _ = process.communicate(timeout=KILL_AFTER_S)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            output, _ = process.communicate()
    text = output.decode("utf-8", "replace")
    if len(text) > MAX_OUTPUT:
        text = "…(cut)…\n" + text[-MAX_OUTPUT:]
    return process.returncode, text, stopped


def main(plan_path: str, phase: str, transcript_path: str) -> int:
    steps = json.loads(Path(plan_path).read_text(encoding="utf-8"))
    env_all = json.loads(Path(plan_path).with_suffix(".env.json").read_text(encoding="utf-8"))
    STATE.mkdir(parents=True, exist_ok=True)
    with Path(transcript_path).open("a", encoding="utf-8") as transcript:
        for index, step in enumerate(steps):
            if step["phase"] != phase:
                continue
            transcript.write(json.dumps({"event": "start", "index": index}) + "\n")
            transcript.flush()
            started = time.monotonic()
            try:
                status, output, stopped = _run(step, env_all)
            except OSError as error:  # the line could not be started: the tier's fault, said
                status, output, stopped = 127, f"deploy tier: could not start: {error}\n", False
            record = {
                "event": "end",
                "index": index,
                "status": status,
                "stopped": stopped,
                "seconds": round(time.monotonic() - started, 2),
                "output": output,
            }
            transcript.write(json.dumps(record) + "\n")
            transcript.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:4]))
