"""Noise on a line-rate receiver's line (docs/SAFETY.md row 80, found by `bywire verify
--draw-robots 8 --budget 800 --seed 9`, file 5, campaign 11, H1): a legal
`sim.rc_frame_period_s = 0.0028` sends IBUS frames back to back. The simulated receiver queued
its frames behind 200 random bytes of noise (17.4 ms of line time), and with 22 µs of slack a
frame the backlog drained over about 2 s: every frame until then arrived up to 17 ms late, so a
switch moved between positions half a second later was seen late, and the robot stopped 10 ms
past the oracle's deadline. A real receiver keeps its schedule; noise garbles the frames it
covers. Judged on the e-brake line: the noise changes nothing once it has passed."""

from __future__ import annotations

import pytest

from bywire.config import parse_config
from bywire.hal.simulated.rc_transmitter import SimRcTransmitter
from tests.system.judged import Judged, armed_in_rc, judged

LINE_RATE = parse_config(
    "[sim]\nrc_frame_period_s = 0.0028\n"
    "[tasks]\nhydrobrake_rate_hz = 1000\n"
    "[timeouts]\ndac_transfer_budget_s = 0.0005\n",
    "line-rate",
)
BETWEEN_S = 1.8  # the switch comes to rest between RC and CAN: STOP (row 49)


def played(*, noise: bool) -> Judged:
    noise_event = ('{ at_s = 1.3, fault = "ibus_garbage", count = 200 }',) if noise else ()
    between = f"{{ at_s = {BETWEEN_S}, rc = {{ mode_raw = 1750 }} }}"
    return judged(LINE_RATE, armed_in_rc("line-rate-noise", 2.2, *noise_event, between))


def _braked_s(run: Judged) -> float:
    armed = run.after(1.0)[0]
    assert armed.motors_enabled
    assert not armed.ebrake_engaged
    return next(s.time_s for s in run.after(BETWEEN_S) if s.ebrake_engaged)


def test_noise_half_a_second_before_changes_nothing_on_a_line_rate_receiver() -> None:
    noisy, quiet = played(noise=True), played(noise=False)
    assert noisy.found == quiet.found == set()
    assert _braked_s(noisy) == _braked_s(quiet)


def test_a_receiver_that_queued_its_frames_behind_the_noise_was_late(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The simulator before: the same noise, the stop 10 ms later, and the oracle flags it
    (so it would flag a controller that took as long)."""

    def queued(rc: SimRcTransmitter, data: bytes) -> None:
        rc._uart.transmit(data)

    monkeypatch.setattr(SimRcTransmitter, "inject_bytes", queued)
    run = played(noise=True)
    assert "H1" in run.found
    assert _braked_s(run) > _braked_s(played(noise=False))
