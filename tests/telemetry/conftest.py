"""What the telemetry tests feed on: the captures of a stretch of the test course."""

from __future__ import annotations

import pytest

from bywire.config import default_sim_config
from bywire.sim.catalog import find_scenario
from bywire.sim.runner import SimRun
from bywire.telemetry.capture import Capture, TelemetryTap
from bywire.telemetry.outbox import Outbox


def course_captures(duration_s: float) -> list[Capture]:
    """Every capture of the first `duration_s` of the course, with every bus frame."""
    sim = SimRun(default_sim_config(), find_scenario("test-course"), duration_s=duration_s)
    outbox: Outbox[Capture] = Outbox(1_000_000)
    tap = TelemetryTap(sim.runtime, outbox).attach()
    sim.add_can_monitor(lambda f: tap.can_frame(f.time_s, f.arbitration_id, f.data, f.sender))
    sim.run()
    return outbox.take(0.0)


@pytest.fixture(scope="session")
def captures() -> list[Capture]:
    """Four seconds of the course: latched, arming, RC driving; state, events and CAN frames."""
    return course_captures(4.0)
