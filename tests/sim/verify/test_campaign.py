"""A campaign's run: what it lets through to the user's terminal."""

from __future__ import annotations

import logging

from bywire.sim.verify.campaign import _quiet_runtime


def test_a_campaign_silences_the_whole_runtimes_log_and_gives_it_back() -> None:
    # `bywire verify --jobs 2` printed "DAC write failed" for every campaign whose fault failed a
    # DAC write: the actuators' logger, a child of the runtime's, was not the one silenced.
    names = ("bywire.runtime.loop", "bywire.runtime.actuators", "bywire.runtime.readers")
    with _quiet_runtime():
        assert not any(logging.getLogger(name).isEnabledFor(logging.ERROR) for name in names)
    assert all(logging.getLogger(name).isEnabledFor(logging.ERROR) for name in names)
