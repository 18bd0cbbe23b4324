"""`bywire keys new` and the StrictModes checks at load; the key never shows in any output."""

from __future__ import annotations

import contextlib
import io
import logging
import os
import stat
from pathlib import Path

import pytest

from bywire.cli.main import main
from bywire.config import load_config
from bywire.errors import ConfigError

NOBODY = 65534


def _bywire(*argv: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main(list(argv))
    return status, out.getvalue(), err.getvalue()


def _secured_config(tmp_path: Path, key: Path) -> Path:
    config = tmp_path / "robot.toml"
    config.write_text(
        f'[security]\nenabled = true\nkey_file = "{key}"\n'
        f'freshness_file = "{tmp_path / "freshness.json"}"\n'
    )
    config.chmod(0o644)
    return config


def test_keys_new_writes_a_private_random_key(tmp_path: Path) -> None:
    first, second = tmp_path / "a.key", tmp_path / "b.key"
    status, out, err = _bywire("keys", "new", str(first))
    assert (status, err) == (0, "")
    assert _bywire("keys", "new", str(second))[0] == 0
    assert stat.S_IMODE(first.stat().st_mode) == 0o600
    secret = first.read_text().strip()
    assert len(bytes.fromhex(secret)) == 16
    assert secret != second.read_text().strip()
    assert secret not in out
    assert "check value" in out


def test_keys_new_never_overwrites(tmp_path: Path) -> None:
    key = tmp_path / "k.key"
    key.write_text("keep me\n")
    status, out, err = _bywire("keys", "new", str(key))
    assert (status, out) == (2, "")
    assert "never overwritten" in err
    assert key.read_text() == "keep me\n"


def test_the_umask_does_not_loosen_the_key(tmp_path: Path) -> None:
    old = os.umask(0)
    try:
        assert _bywire("keys", "new", str(tmp_path / "k.key"))[0] == 0
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "k.key").stat().st_mode) == 0o600


@pytest.mark.parametrize("mode", [0o640, 0o604, 0o620, 0o602, 0o644])
def test_a_key_others_may_read_or_write_is_refused(tmp_path: Path, mode: int) -> None:
    key = tmp_path / "k.key"
    assert _bywire("keys", "new", str(key))[0] == 0
    key.chmod(mode)
    status, out, err = _bywire("config", "check", str(_secured_config(tmp_path, key)))
    assert (status, out) == (2, "")
    assert f"key file has mode {mode:04o}" in err
    assert "chmod 0600" in err


@pytest.mark.parametrize("mode", [0o664, 0o646])
def test_a_configuration_others_may_write_is_refused(tmp_path: Path, mode: int) -> None:
    key = tmp_path / "k.key"
    assert _bywire("keys", "new", str(key))[0] == 0
    config = _secured_config(tmp_path, key)
    config.chmod(mode)
    status, _, err = _bywire("config", "check", str(config))
    assert status == 2
    assert f"configuration file has mode {mode:04o}" in err


def test_a_loose_configuration_is_fine_while_authentication_is_off(tmp_path: Path) -> None:
    config = tmp_path / "robot.toml"
    config.write_text("[security]\nenabled = false\n")
    config.chmod(0o666)
    assert load_config(config).security.enabled is False


def test_a_malformed_key_file_is_refused(tmp_path: Path) -> None:
    key = tmp_path / "k.key"
    key.write_text("not hex\n")
    key.chmod(0o600)
    status, _, err = _bywire("config", "check", str(_secured_config(tmp_path, key)))
    assert status == 2
    assert "not a key file" in err


def test_config_check_says_whether_authentication_is_on(tmp_path: Path) -> None:
    plain = tmp_path / "plain.toml"
    plain.write_text("")
    status, out, _ = _bywire("config", "check", str(plain))
    assert status == 0
    assert out.splitlines()[1].startswith("# authentication: off")
    key = tmp_path / "k.key"
    assert _bywire("keys", "new", str(key))[0] == 0
    status, out, err = _bywire("config", "check", str(_secured_config(tmp_path, key)))
    assert (status, err) == (0, "")
    assert out.splitlines()[1].startswith("# authentication: on (SecOC profile 3")
    assert "enabled = true" in out


def test_the_key_reaches_no_output_or_log(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.DEBUG)
    key = tmp_path / "k.key"
    outputs = [_bywire("keys", "new", str(key))]
    secret = key.read_text().strip()
    config = _secured_config(tmp_path, key)
    outputs += [_bywire("config", "check", str(config))]
    outputs += [_bywire("config", "check", "--json", str(config))]
    mcap = tmp_path / "run.mcap"
    outputs += [
        _bywire("sim", "--config", str(config), "--duration", "1", "--json", "--mcap", str(mcap))
    ]
    text = "".join(out + err for _, out, err in outputs) + caplog.text
    assert [status for status, _, _ in outputs] == [0, 0, 0, 0]
    assert "authentication: on" in outputs[1][1]
    assert secret not in text.lower()
    assert secret.upper() not in text
    telemetry = mcap.read_bytes()  # the telemetry feed, every channel
    assert len(telemetry) > 1000
    assert bytes.fromhex(secret) not in telemetry
    assert secret.encode() not in telemetry.lower()
    assert repr(load_config(config)).count(secret) == 0


def test_the_controller_refuses_to_start_without_its_freshness_file(tmp_path: Path) -> None:
    from bywire.config.security import SecuritySection  # noqa: PLC0415
    from bywire.protocol.secoc import SecocKey  # noqa: PLC0415
    from bywire.security.setup import controller_receiver  # noqa: PLC0415

    written = tmp_path / "freshness.json"
    security = SecuritySection(enabled=True, key_file="k", freshness_file=str(written))
    with pytest.raises(ConfigError, match=r"bywire keys reset-freshness --config robot\.toml"):
        controller_receiver(security, SecocKey(bytes(16)), "robot.toml")
    assert not written.exists()


def test_reset_freshness_makes_the_file_once_and_the_start_moves_its_trip_on(
    tmp_path: Path,
) -> None:
    key = tmp_path / "k.key"
    assert _bywire("keys", "new", str(key))[0] == 0
    config = _secured_config(tmp_path, key)
    status, out, err = _bywire("keys", "reset-freshness", "--config", str(config))
    assert (status, err) == (0, "")
    assert "starts above 0" in out
    assert stat.S_IMODE((tmp_path / "freshness.json").stat().st_mode) == 0o600
    (tmp_path / "freshness.json").write_text("damaged")
    status, out, err = _bywire("keys", "reset-freshness", "--config", str(config), "--trip", "9")
    assert status == 0
    assert "the old file is kept as" in out
    kept = [p for p in tmp_path.iterdir() if ".replaced-" in p.name]
    assert [p.read_text() for p in kept] == ["damaged"]


@pytest.mark.skipif(os.geteuid() != 0, reason="needs root to give files to another user")
def test_reset_freshness_as_root_gives_the_file_to_the_state_folders_owner(
    tmp_path: Path,
) -> None:
    key = tmp_path / "k.key"
    assert _bywire("keys", "new", str(key))[0] == 0
    state = tmp_path / "state"
    state.mkdir()
    os.chown(state, NOBODY, NOBODY)
    config = tmp_path / "robot.toml"
    config.write_text(
        f'[security]\nenabled = true\nkey_file = "{key}"\n'
        f'freshness_file = "{state / "freshness.json"}"\n'
    )
    assert _bywire("keys", "reset-freshness", "--config", str(config))[0] == 0
    assert (state / "freshness.json").stat().st_uid == NOBODY


@pytest.mark.skipif(os.geteuid() != 0, reason="needs root to make a file another user owns")
@pytest.mark.parametrize("what", ["key file", "configuration file"])
def test_a_file_another_user_owns_is_refused(tmp_path: Path, what: str) -> None:
    key = tmp_path / "k.key"
    assert _bywire("keys", "new", str(key))[0] == 0
    config = _secured_config(tmp_path, key)
    os.chown(key if what == "key file" else config, NOBODY, NOBODY)
    status, _, err = _bywire("config", "check", str(config))
    assert status == 2
    assert f"{what} is owned by nobody, not by the user running bywire (root) or root" in err
    assert "chown root" in err


@pytest.mark.parametrize("mode", [0o777, 0o775, 0o757])
def test_a_key_in_a_folder_others_may_write_is_refused(tmp_path: Path, mode: int) -> None:
    folder = tmp_path / "keys"
    folder.mkdir()
    key = folder / "k.key"
    assert _bywire("keys", "new", str(key))[0] == 0
    folder.chmod(mode)
    status, _, err = _bywire("config", "check", str(_secured_config(tmp_path, key)))
    assert status == 2
    assert f"the key file's folder {folder} has mode {mode:04o}" in err
    folder.chmod(0o755)
    assert _bywire("config", "check", str(_secured_config(tmp_path, key)))[0] == 0
