"""`python -m bywire.bench.onlooker URL`: a Foxglove client of every channel of the feed, in a
process of its own, that decodes each message and throws it away; on SIGTERM it closes the
connection and prints how many it received. The benchmark's stand-in for Foxglove watching."""

from __future__ import annotations

import signal
import sys
import threading

from bywire.dashboard.client import FeedClient
from bywire.telemetry.schemas import SCHEMAS


def main(argv: list[str]) -> int:
    done = threading.Event()
    signal.signal(signal.SIGTERM, lambda _number, _frame: done.set())
    client = FeedClient(argv[0], topics=tuple(SCHEMAS)).start()
    while not done.wait(0.1) and not client.ended:
        pass
    client.close()  # with a closing handshake: the server has nothing to complain of
    print(client.received, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
