"""Drawing robot files across the loader's legal space (`bywire verify --draw-robots`): every key
that picks no hardware reaches the ends of the range the loader itself checks, the hardware picks
stay as the base file has them, every drawn file loads, and the same seed draws the same files."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import pytest

from bywire.config import RobotConfig, actuators, parse_config
from bywire.config.loader import read_schema
from bywire.config.reader import Interval, KeyRead
from bywire.sim.verify.robots import (
    DrawnRobot,
    Schema,
    dotted,
    draw_robot,
    draw_robots,
    keys_needed,
    picks_hardware,
    robot_with,
    rule_of,
)

ROOT = Path(__file__).resolve().parents[3]
SIM = ROOT / "src" / "bywire" / "defaults" / "sim.toml"
ALBERT = ROOT / "config" / "albert.toml"
FILES = 30


@pytest.fixture(scope="module")
def sim() -> Schema:
    return Schema.of(SIM.read_text(), str(SIM))


@pytest.fixture(scope="module")
def drawn(sim: Schema) -> list[DrawnRobot]:
    return list(draw_robots(sim, 0, FILES))


def _at(data: dict[str, object], parts: tuple[str, ...]) -> object:
    value: object = data
    for part in parts:
        assert isinstance(value, dict)
        value = value[part]
    return value


def _ends(read: KeyRead) -> set[str]:
    """Which ends of its range `read`'s value sits at (an open end: just inside)."""
    allowed, value = read.allowed, read.value
    if isinstance(allowed, Interval):
        assert isinstance(value, float | int)
        span = (allowed.high if math.isfinite(allowed.high) else value) - allowed.low
        near = span * 1e-3
        low = (
            allowed.low < value <= allowed.low + near if allowed.low_open else value == allowed.low
        )
        high = (
            allowed.high - near <= value < allowed.high
            if allowed.high_open
            else value == allowed.high
        )
        return {name for name, hit in (("low", low), ("high", high)) if hit}
    if isinstance(allowed, range):
        values = list(value) if isinstance(value, tuple | list) else [value]
        return {
            name
            for name, hit in (("low", allowed.start in values), ("high", allowed[-1] in values))
            if hit
        }
    return {"low", "high"} if read.kind == "flag" else set()


def _values(robot: DrawnRobot, _schema: Schema) -> dict[str, KeyRead]:
    """The drawn file's keys as the loader reads them."""
    return {dotted(read.parts): read for read in read_schema(robot.text)}


def test_the_same_seed_draws_the_same_files_and_another_seed_others(sim: Schema) -> None:
    first = [robot.text for robot in draw_robots(sim, 7, 3)]
    assert first == [robot.text for robot in draw_robots(sim, 7, 3)]
    assert draw_robot(sim, 7, 2).text == first[1]  # a file is drawn alone as in a run
    assert len(set(first)) == 3
    assert not set(first) & {robot.text for robot in draw_robots(sim, 8, 3)}


def test_every_drawn_file_loads_and_differs_from_the_base_on_many_keys(
    sim: Schema, drawn: list[DrawnRobot]
) -> None:
    for robot in drawn:
        assert parse_config(robot.text) == robot.robot
        values = _values(robot, sim)
        differing = [
            read.parts for read in sim.keys if values[dotted(read.parts)].value != read.value
        ]
        assert len(differing) == len(robot.changed)
        assert len(differing) >= len(sim.keys) // 3, robot.index


def test_every_key_but_the_hardware_picks_reaches_both_ends_of_the_loaders_range(
    sim: Schema, drawn: list[DrawnRobot]
) -> None:
    """Not a second list of keys: the ranges are the loader's own (the schema), and every key it
    reads with a range is drawn to each end in some file, unless a rule refuses that end given
    the other keys (min < centre < max, a deadline row): then the refusal is reported, and the
    draw moves as near that end as the rule allows."""
    assert len(sim.keys) > 70
    reached: dict[str, set[str]] = {dotted(read.parts): set() for read in sim.keys}
    for robot in drawn:
        for name, read in _values(robot, sim).items():
            if name in reached:
                reached[name] |= _ends(read)
    short = [name for name, ends in reached.items() if len(ends) < 2]
    # the triples, the timeouts, a few rates, and the ends the deadline rows refuse (issue 41:
    # steering monitor, no-sensor brake, controlled stop, pairing window, pressure monitor, the
    # stop promises' budgets): fewer than half, and each one repaired by a rule that names it
    assert len(short) < len(reached) // 2, short
    repaired = {repair.key for robot in drawn for repair in robot.repairs}
    assert set(short) <= repaired


def test_open_ends_are_drawn_just_inside(drawn: list[DrawnRobot]) -> None:
    servo = {robot.robot.steering.servo.servo_speed_norm_per_s for robot in drawn}
    threshold = {robot.robot.hydrobrake.threshold_norm for robot in drawn}
    assert 0.0 < min(servo) <= 0.01  # POSITIVE_NORM_PER_S: > 0
    assert 0.999 <= max(threshold) < 1.0  # THRESHOLD_NORM: < 1


@pytest.mark.parametrize("path", [SIM, ALBERT], ids=["sim", "albert"])
def test_the_hardware_picks_stay_as_the_base_file_has_them(path: Path) -> None:
    schema = Schema.of(path.read_text(), str(path))
    kept = {dotted(read.parts) for read in schema.kept}
    assert {"backend", "can.interface", "drive.dac.address", "rc.mode_switch.channel"} <= kept
    assert all(picks_hardware(read) for read in schema.kept)
    base = tomllib.loads(path.read_text())
    for robot in draw_robots(schema, 1, 5):
        data = tomllib.loads(robot.text)
        assert data["backend"] == base["backend"]
        for read in schema.kept:
            assert (
                _at(data, read.parts) == _at(base, read.parts) if _has(base, read.parts) else True
            )
        assert robot.robot.drive.motors_enable == parse_config(path.read_text()).drive.motors_enable


def _has(data: dict[str, object], parts: tuple[str, ...]) -> bool:
    try:
        _at(data, parts)
    except KeyError:
        return False
    return True


def test_a_refused_draw_is_repaired_toward_the_base_naming_the_rule(
    sim: Schema, drawn: list[DrawnRobot]
) -> None:
    repaired = [robot for robot in drawn if robot.repairs]
    assert repaired
    for robot in repaired:
        values = _values(robot, sim)
        for repair in robot.repairs:
            value = values[repair.key].value
            assert value == repair.kept or list(value) == repair.kept  # type: ignore[call-overload]
            assert repair.kept != repair.drawn
            assert repair.rule in robot.refusals
    kept = [r for robot in repaired for r in robot.repairs if r.kept != r.base]
    assert kept  # a refused edge traded for the nearest value the other keys allow
    rules = {rule for robot in drawn for rule in robot.refusals}
    assert any("must increase (min < center < max)" in rule for rule in rules)
    assert any("deadline '" in rule for rule in rules)


def test_a_rule_is_named_without_its_values() -> None:
    message = "steering.min_pulse_s = 0.0025: must increase (min < center < max)"
    assert rule_of(message) == "steering.min_pulse_s: must increase (min < center < max)"
    breach = "a.b + c.d: breaks the deadline 'a stall is no longer than a loss': x 1.0 > 0.2; y"
    assert rule_of(breach) == "a.b + c.d: deadline 'a stall is no longer than a loss'"


def test_a_range_the_loader_widens_is_drawn_to_its_new_end(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The drawer holds no ranges of its own: widen one in the loader and it is drawn there (a
    range no deadline row narrows: the steering tolerance's once, now row 50's)."""
    monkeypatch.setattr(actuators, "BLINK_HZ", Interval(0.5, 50.0, "Hz"))
    schema = Schema.of(SIM.read_text())
    highest = max(robot.robot.lights.blink_rate_hz for robot in draw_robots(schema, 0, 10))
    assert highest == 50.0


def test_the_keys_a_failure_needs_are_those_without_which_it_goes(sim: Schema) -> None:
    """Six drawn keys, a failure that needs two of them together: the other four go back to the
    base file's values, and the two stay (`bywire verify --draw-robots` names them)."""
    changed: dict[str, object] = {
        "lights.blink_rate_hz": 0.6,
        "monitors.steering_tolerance_norm": 0.25,
        "sim.top_speed_mps": 3.5,
        "timeouts.rc_timeout_s": 0.06,
        "tasks.lights_rate_hz": 1000.0,
        "steering.rate_limit_norm_per_s": 12.0,
    }
    assert robot_with(sim, changed) is not None
    tried: list[RobotConfig] = []

    def fails(robot: RobotConfig) -> bool:
        tried.append(robot)
        return robot.sim.top_speed_mps == 3.5 and robot.timeouts.rc_timeout_s == 0.06

    assert keys_needed(sim, changed, fails) == {
        "sim.top_speed_mps": 3.5,
        "timeouts.rc_timeout_s": 0.06,
    }
    assert len(tried) < 2 * len(changed)  # chunks first, then one by one
    assert keys_needed(sim, changed, lambda _robot: False) == changed  # nothing can go
