"""The reports on the bus: WheelSpeedReport's `speed_limited` bit is 1 exactly while the speed
governor acts (read off the frames the simulated computer receives, not the controller's state)."""

from __future__ import annotations

from dataclasses import replace

from bywire.config import default_sim_config
from bywire.config.speed_limit import LimitsSection
from bywire.hal.simulated.can_bus import LoggedFrame
from bywire.model import WheelSpeedReport
from bywire.protocol import dbc
from bywire.sim.catalog import packaged_scenarios
from bywire.sim.runner import SimRun


def _wheel_reports(limits: LimitsSection | None = None) -> list[tuple[float, WheelSpeedReport]]:
    robot = default_sim_config()
    if limits is not None:
        robot = replace(robot, limits=limits)
    run = SimRun(robot, packaged_scenarios()["speed-limit-slope"])
    reports: list[tuple[float, WheelSpeedReport]] = []

    def tap(frame: LoggedFrame) -> None:
        if frame.arbitration_id == dbc.frame_id(WheelSpeedReport):
            report = dbc.decode_report(frame.arbitration_id, frame.data)
            assert isinstance(report, WheelSpeedReport)
            reports.append((frame.time_s, report))

    run.add_can_monitor(tap)
    run.run()
    return reports


def test_speed_limited_is_reported_while_the_governor_acts_and_not_before() -> None:
    reports = _wheel_reports()
    # from a standstill the sensor's reading is unproven until it reads motion, so the ceiling
    # may act for the first few centimetres per second; rolling below the band, nothing acts
    slow = [report for _, report in reports if 0.3 < report.left_mps < 1.5]
    fast = [report for t, report in reports if t > 7.0]  # downhill, held near the limit
    assert slow
    assert not any(report.speed_limited for report in slow)
    assert fast
    assert all(report.speed_limited for report in fast)


def test_without_a_limit_nothing_is_reported_limited() -> None:
    reports = _wheel_reports(LimitsSection(None))
    assert reports
    assert not any(report.speed_limited for _, report in reports)
