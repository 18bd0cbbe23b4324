"""`bywire` in a test's subprocess, with the stand-ins this machine lacks.

Usage: python launch_bywire.py HLC_DIR CAN_CHANNEL -- BYWIRE_ARGS...

- PWM: the fake sysfs tree refuses what the kernel's PWM core refuses (`pwm_core_checks`).
- GPIO: the file-backed `fake_gpiod` is installed as `gpiod` before bywire imports it, so the
  real backend (`bywire.hal.linux.gpio_gpiod`) runs against it.
- CAN: python-can's virtual bus exists only inside one process, so the higher-level computer
  runs here, on a second virtual bus: every 20 ms it sends the MovementCommand that the test
  wrote to HLC_DIR/movement.json (nothing while there is none) and counts the reports it
  receives into HLC_DIR/reports.json, with the last changes of mode, arming and error flags (their
  time on this process's monotonic clock and the age of the last movement command sent): what a
  test that waited in vain tells. With a key file HLC_DIR/private/hlc.key (in a folder only
  its owner may write, as bywire requires of a key's folder) it signs each command
  (SecOC cryptographic PDU) in the trip the controller announces, its freshness kept in
  HLC_DIR/freshness.json.
"""

from __future__ import annotations

import json
import os
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))  # the repository, for `tests`
import pytest

from tests.hal.linux import fake_gpiod
from tests.hal.linux.fake_sysfs import pwm_core_checks

sys.modules["gpiod"] = fake_gpiod
pwm_core_checks(pytest.MonkeyPatch())

import can  # noqa: E402

from bywire.cli.main import main  # noqa: E402
from bywire.config.security_setup import sender_signer  # noqa: E402
from bywire.model import ErrorReport, Gear, ModeReport, MovementCommand  # noqa: E402
from bywire.protocol import dbc  # noqa: E402
from bywire.security.keys import read_key_file  # noqa: E402
from bywire.security.session import TRIP_IDS  # noqa: E402

PERIOD_S = 0.02
CHANGES_KEPT = 12


def higher_level_computer(folder: Path, channel: str, stop: threading.Event) -> None:
    bus = can.Bus(interface="virtual", channel=channel)
    counter, counts, mode, armed, flags = 0, 0, None, None, "unknown"
    sent_s, changes = float("nan"), list[dict[str, object]]()
    key = folder / "private" / "hlc.key"
    signer = sender_signer(read_key_file(key), folder / "freshness.json") if key.exists() else None
    try:
        while not stop.wait(PERIOD_S):
            command = folder / "movement.json"
            if command.exists():
                fields = json.loads(command.read_text())
                movement = MovementCommand(
                    fields["steering"],
                    fields["throttle"],
                    fields["brake"],
                    Gear[fields["gear"].upper()],
                    counter,
                )
                frame_id, payload = dbc.encode_command(movement)
                auth = None if signer is None else signer.authenticator(frame_id, payload)
                if signer is None or auth is not None:  # unsigned: wait for the trip counter
                    frames = [(frame_id, payload)]
                    frames += [] if auth is None else [(auth.arbitration_id, auth.data)]
                    for arbitration_id, data in frames:
                        bus.send(
                            can.Message(
                                arbitration_id=arbitration_id, data=data, is_extended_id=False
                            )
                        )
                    counter = (counter + 1) % dbc.COUNTER_MODULUS
                    sent_s = time.monotonic()
            while (message := bus.recv(0)) is not None:
                if message.arbitration_id in TRIP_IDS:
                    if signer is not None:
                        signer.hear(message.arbitration_id, bytes(message.data))
                    continue
                counts += 1
                report = dbc.decode_report(message.arbitration_id, bytes(message.data))
                before = (mode, armed, flags)
                if isinstance(report, ModeReport):
                    mode, armed = report.control_mode.name, report.armed
                elif isinstance(report, ErrorReport):
                    flags = report.flags.name or "none"
                if (mode, armed, flags) != before:
                    now_s = time.monotonic()
                    changes.append(
                        {
                            "t": round(now_s, 3),
                            "mode": mode,
                            "armed": armed,
                            "flags": flags,
                            "command_age_s": round(now_s - sent_s, 3),
                        }
                    )
                    del changes[:-CHANGES_KEPT]
            temporary = folder / "reports.tmp"
            temporary.write_text(
                json.dumps(
                    {
                        "reports": counts,
                        "mode": mode,
                        "armed": armed,
                        "flags": flags,
                        "changes": changes,
                    }
                )
            )
            os.replace(temporary, folder / "reports.json")
    finally:
        bus.shutdown()
        if signer is not None:
            signer.close()


if __name__ == "__main__":
    hlc_dir, can_channel, separator, *bywire_args = sys.argv[1:]
    stopping = threading.Event()
    thread = threading.Thread(
        target=higher_level_computer, args=(Path(hlc_dir), can_channel, stopping), daemon=True
    )
    thread.start()
    status = main(bywire_args)
    stopping.set()
    thread.join(timeout=5.0)
    sys.exit(status)
