"""`bywire bench --look`: the looking phases on real time, with real onlooker processes: a
Foxglove client that receives the feed during the "feed" phase, and the dashboard's child
process during the "dashboard" phase; every phase yields its figures and the titles say what
was looking."""

from __future__ import annotations

import pytest

from bywire.bench.clocks import MeteredRealtimeClock
from bywire.bench.figures import BenchResult
from bywire.bench.realtime_session import BenchSettings, RealtimeSession
from bywire.bench.table import section_title
from bywire.bench.virtual import measure_speedup
from bywire.config import default_sim_config


def test_the_looking_phases_run_with_their_onlookers_and_yield_every_figure(
    capfd: pytest.CaptureFixture[str],
) -> None:
    robot = default_sim_config()
    session = RealtimeSession(
        robot, BenchSettings(phase_s=1.5, settle_s=0.2, look=True), MeteredRealtimeClock()
    )
    result = session.run()
    assert [phase.name for phase in result.phases] == ["nominal", "flood", "feed", "dashboard"]
    for phase in result.phases:
        assert {task.name for task in phase.tasks} >= {"steering", "driving", "hydrobrake"}
        assert all(task.runs > 0 for task in phase.tasks)
    for phase in result.phases[2:]:  # at nominal load, with the onlookers attached
        assert phase.can_latency.samples > 0
        assert phase.ibus_latency.samples > 0
    assert session.onlookers is not None
    # The client process was attached and received the feed (state, events, CAN frames).
    assert session.onlookers.received["feed"] > 50
    bench = BenchResult(result, measure_speedup(robot, "test-course", 1.0), None, {}, {})
    assert "Foxglove client attached" in section_title(bench, "feed")
    assert "bywire dashboard attached" in section_title(bench, "dashboard")
    # Both onlookers leave with a closing handshake: the server (in the writer's process, on
    # this stderr) has no "connection reset" to print into the user's terminal.
    assert "reset" not in capfd.readouterr().err
