"""The deploy tier's fresh Debian machine: its base, made once by debootstrap and kept as a
tarball in a cache outside the clone; a new root from it for every run, in a tmpfs; a clone of
this checkout in it; and its boots under systemd-nspawn (systemd as PID 1, journald, logind,
systemctl and systemd-networkd for real; udevd cannot run in a container, see ./udevadm).

The base is Debian 12 (bookworm, the robot's OS family), `--variant=minbase`, with what the
README asks of a fresh machine (Python 3.11 with pip) and what a booted Debian 12 has (systemd as
init, udev, D-Bus, sudo), a developer account (`dev`) and the hostname `robot`: no git, no venv,
no compiler, which the docs' own lines must install. Only this machine's package-access set-up
is carried in at each run: its extra CA certificates and /etc/pip.conf (where a site's proxy or
mirror needs them; nothing else of the host's).

Cache: $BYWIRE_DEPLOY_CACHE, else $XDG_CACHE_HOME/bywire-deploy (~/.cache/bywire-deploy):
`base-<key>.tar` (the key hashes the recipe below), `debs/` (debootstrap's downloads), and the
run's tmpfs at `run/` while a run lasts (left mounted for a look with BYWIRE_DEPLOY_KEEP=1).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
import subprocess
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import asdict
from pathlib import Path

from tests.deploy.commands import REMOTE_IN_GUEST, REMOTE_VARIABLE, ROOT, Step

HERE = Path(__file__).resolve().parent
SUITE = "bookworm"
MIRROR = os.environ.get("BYWIRE_DEPLOY_MIRROR", "http://deb.debian.org/debian")
SECURITY_MIRROR = "http://deb.debian.org/debian-security"
PACKAGES = ("python3", "python3-pip", "sudo", "systemd", "systemd-sysv", "udev", "dbus")
HOSTNAME = "robot"
# Run in the new tree (chroot) once, before it is packed: what an installed Debian 12 has.
SETUP = (
    "apt-get clean",
    f"printf 'deb {MIRROR} {SUITE} main\\ndeb {MIRROR} {SUITE}-updates main\\n"
    f"deb {SECURITY_MIRROR} {SUITE}-security main\\n' > /etc/apt/sources.list",
    f"echo {HOSTNAME} > /etc/hostname",
    f"printf '127.0.1.1\\t{HOSTNAME}\\n' >> /etc/hosts",
    "useradd --create-home --shell /bin/bash dev",
)
TMPFS_SIZE = "8g"
GUEST_DIR = "/usr/local/lib/bywire-deploy-tier"
TRANSCRIPTS = "/var/log/bywire-deploy-tier"  # transcript-<phase>.jsonl, one a boot
UNIT = "bywire-deploy-tier.service"
BOOT_LIMIT_S = 20 * 60
# No udev in a container, so no device unit ever appears there: the container's systemd gives up
# on one after 5 s instead of 90 (bywire.service waits for can0's). A boot setting of the test
# machine, not of the project's files.
BOOT_ARGS = ("systemd.default_device_timeout_sec=5",)


def cache_dir() -> Path:
    explicit = os.environ.get("BYWIRE_DEPLOY_CACHE")
    if explicit:
        return Path(explicit)
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "bywire-deploy"


def _say(message: str) -> None:
    print(f"deploy tier: {message}", flush=True)


def _recipe_key() -> str:
    recipe = json.dumps([SUITE, MIRROR, PACKAGES, SETUP])
    return hashlib.sha256(recipe.encode()).hexdigest()[:12]


@contextmanager
def _tmpfs(mountpoint: Path, keep: bool = False) -> Iterator[Path]:
    if os.path.ismount(mountpoint):
        subprocess.run(["umount", "--lazy", str(mountpoint)], check=True)
    mountpoint.mkdir(parents=True, exist_ok=True)
    subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={TMPFS_SIZE},mode=0755", "tmpfs", str(mountpoint)],
        check=True,
    )
    try:
        yield mountpoint
    finally:
        if not keep:
            subprocess.run(["umount", "--lazy", str(mountpoint)], check=False)


def base_tarball() -> tuple[Path, bool]:
    """The cached base (made now if missing) and whether it was made now."""
    cache = cache_dir()
    tarball = cache / f"base-{SUITE}-{_recipe_key()}.tar"
    if tarball.exists():
        return tarball, False
    cache.mkdir(parents=True, exist_ok=True)
    log = cache / "debootstrap.log"
    _say(f"making the Debian {SUITE} base with debootstrap (log: {log})")
    (cache / "debs").mkdir(exist_ok=True)
    with _tmpfs(cache / "build") as build, log.open("w") as output:
        root = build / "root"
        made = subprocess.run(
            [
                "debootstrap",
                "--variant=minbase",
                f"--include={','.join(PACKAGES)}",
                f"--cache-dir={cache / 'debs'}",
                SUITE,
                str(root),
                MIRROR,
            ],
            stdout=output,
            stderr=subprocess.STDOUT,
            check=False,
        )
        if made.returncode != 0:
            tail = log.read_text(errors="replace").splitlines()[-5:]
            raise RuntimeError(f"debootstrap failed (exit {made.returncode}): " + " | ".join(tail))
        for command in SETUP:
            subprocess.run(["chroot", str(root), "/bin/sh", "-c", command], check=True)
        partial = tarball.with_suffix(".partial")
        subprocess.run(
            ["tar", "--numeric-owner", "--xattrs", "-C", str(root), "-cf", str(partial), "."],
            check=True,
        )
        partial.rename(tarball)
    for old in cache.glob(f"base-{SUITE}-*.tar"):
        if old != tarball:
            old.unlink()
    return tarball, True


def _snapshot(bare: Path) -> str:
    """This checkout as it is (tracked and untracked files, not ignored ones: what a commit of
    it would hold) as the one commit of a new bare repository; returns the commit."""
    env = {
        **os.environ,
        "GIT_AUTHOR_NAME": "deploy tier",
        "GIT_AUTHOR_EMAIL": "deploy-tier@localhost",
        "GIT_COMMITTER_NAME": "deploy tier",
        "GIT_COMMITTER_EMAIL": "deploy-tier@localhost",
    }

    def git(*args: str, extra: dict[str, str] | None = None) -> str:
        done = subprocess.run(
            ["git", *args],
            cwd=ROOT,
            env={**env, **(extra or {})},
            capture_output=True,
            text=True,
            check=True,
        )
        return done.stdout.strip()

    with tempfile.TemporaryDirectory() as scratch:
        index = {"GIT_INDEX_FILE": str(Path(scratch) / "index")}
        git("add", "--all", ".", extra=index)
        tree = git("write-tree", extra=index)
    commit = git("commit-tree", tree, "-m", "deploy tier: this checkout as it is")
    subprocess.run(["git", "init", "--quiet", "--bare", "-b", "main", str(bare)], check=True)
    git("push", "--quiet", str(bare), f"{commit}:refs/heads/main")
    return commit


def _carry_package_access(root: Path) -> None:
    """The host's extra CA certificates and /etc/pip.conf, so the guest reaches the package
    registries the way this machine does."""
    extra_cas = sorted(Path("/usr/local/share/ca-certificates").glob("*.crt"))
    for certificate in extra_cas:
        shutil.copy(certificate, root / "usr/local/share/ca-certificates" / certificate.name)
    if extra_cas:
        subprocess.run(
            ["chroot", str(root), "update-ca-certificates"], check=True, capture_output=True
        )
    if Path("/etc/pip.conf").exists():
        shutil.copy("/etc/pip.conf", root / "etc/pip.conf")


def prepare(root: Path, steps: list[Step]) -> str:
    """Puts into the new root what the tier needs there; returns the commit it carries."""
    commit = _snapshot(root / REMOTE_IN_GUEST.lstrip("/"))
    # The clone stands in for a network remote, which git's ownership check does not apply to:
    # root owns it here, and the developer clones it too.
    (root / "etc/gitconfig").write_text(f"[safe]\n\tdirectory = {REMOTE_IN_GUEST}\n", "utf-8")
    _carry_package_access(root)
    shutil.copy(HERE / "udevadm", root / "usr/local/sbin/udevadm")
    guest = root / GUEST_DIR.lstrip("/")
    guest.mkdir(parents=True)
    shutil.copy(HERE / "guest.py", guest / "guest.py")
    (guest / "plan.json").write_text(json.dumps([asdict(step) for step in steps]), "utf-8")
    (guest / "plan.env.json").write_text(json.dumps({REMOTE_VARIABLE: REMOTE_IN_GUEST}), "utf-8")
    (root / TRANSCRIPTS.lstrip("/")).mkdir(parents=True)
    return commit


@contextmanager
def fresh_root(tarball: Path) -> Iterator[Path]:
    """A new root from the base, in a tmpfs, gone afterwards (kept with BYWIRE_DEPLOY_KEEP=1)."""
    keep = os.environ.get("BYWIRE_DEPLOY_KEEP") == "1"
    with _tmpfs(cache_dir() / "run", keep=keep) as run:
        root = run / "root"
        root.mkdir()
        subprocess.run(
            ["tar", "--numeric-owner", "--xattrs", "-C", str(root), "-xf", str(tarball)],
            check=True,
        )
        yield root
        if keep:
            _say(f"the guest's root is kept at {root} (umount {run} when done)")


def _transcript(phase: str) -> str:
    return f"{TRANSCRIPTS}/transcript-{phase}.jsonl"


def _unit(phase: str) -> str:
    return (
        "[Unit]\n"
        f"Description=bywire deploy tier: the docs' commands, {phase} phase\n"
        "After=multi-user.target\n"
        "SuccessAction=poweroff\n"
        "FailureAction=poweroff\n"
        "[Service]\n"
        "Type=oneshot\n"
        f"ExecStart=/usr/bin/python3 {GUEST_DIR}/guest.py {GUEST_DIR}/plan.json {phase}"
        f" {_transcript(phase)}\n"
        "TimeoutStartSec=infinity\n"
    )


def boot(root: Path, phase: str, on_record: Callable[[dict[str, object]], None]) -> float:
    """Boots the root, which runs the phase's lines at the end of its boot and powers off;
    `on_record` gets each transcript record as it comes. Offline: a private network namespace
    (loopback only). Returns the seconds it took."""
    units = root / "etc/systemd/system"
    (units / UNIT).write_text(_unit(phase), encoding="utf-8")
    wants = units / "multi-user.target.wants"
    wants.mkdir(exist_ok=True)
    if not (wants / UNIT).is_symlink():
        (wants / UNIT).symlink_to(f"/etc/systemd/system/{UNIT}")
    command = [
        "systemd-nspawn",
        "--quiet",
        "--register=no",
        "--keep-unit",
        f"--directory={root}",
        f"--hostname={HOSTNAME}",
        "--console=pipe",
        *(["--private-network"] if phase == "offline" else []),
        "--boot",
        *BOOT_ARGS,
    ]
    transcript = root / _transcript(phase).lstrip("/")
    log = cache_dir() / f"boot-{phase}.log"
    started = time.monotonic()
    with log.open("w") as output:
        machine = subprocess.Popen(
            command, stdin=subprocess.DEVNULL, stdout=output, stderr=subprocess.STDOUT
        )
        read = 0
        try:
            while True:
                done = machine.poll() is not None
                if transcript.exists():
                    with transcript.open("rb") as records:
                        records.seek(read)
                        for line in records:
                            if not line.endswith(b"\n"):
                                break
                            read += len(line)
                            on_record(json.loads(line))
                if done:
                    break
                if time.monotonic() - started > BOOT_LIMIT_S:
                    _say(f"{phase} boot: time limit ({BOOT_LIMIT_S} s): stopped")
                    machine.send_signal(signal.SIGTERM)
                    machine.wait(timeout=30)
                    break
                time.sleep(0.5)
        finally:
            if machine.poll() is None:
                machine.kill()
                machine.wait()
    if machine.returncode != 0:
        _say(f"{phase} boot: systemd-nspawn exited {machine.returncode} (log: {log})")
    return time.monotonic() - started
