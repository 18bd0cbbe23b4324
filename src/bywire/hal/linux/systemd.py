"""systemd service notifications (sd_notify): READY=1, WATCHDOG=1, STOPPING=1, STATUS=..."""

from __future__ import annotations

import logging
import os
import socket

log = logging.getLogger(__name__)


def notify(state: str) -> None:
    """Send `state` to the service manager; nothing happens when not run by systemd.

    Never raises: a service manager that went away must not stop the controller. Never waits
    either: the datagram is sent without blocking, so a manager that stopped reading its socket
    (its queue full) costs this notification, not the watchdog thread that sends it.
    """
    address = os.environ.get("NOTIFY_SOCKET")
    if not address:
        return
    if address.startswith("@"):  # abstract namespace socket
        address = "\0" + address[1:]
    try:
        with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as sock:
            sock.setblocking(False)
            sock.sendto(state.encode(), address)
    except OSError as error:
        log.warning("sd_notify %s failed: %s", state, error)
