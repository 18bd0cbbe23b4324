"""Safety under sequences nobody picked: random interleavings of sticks, switches (chatter
included), RC loss, failsafe and implausible frames, CAN commands with gaps, repeats and a
second sender, remote stops and re-enables, DAC NAK patterns, stalls inside a DAC write and a
dead wheel-speed sensor, on the whole controller and the simulated robot. The oracle
(`bywire.sim.verify.oracle`) checks the hardware's levels after every pass of the loop; hypothesis
shrinks a failure to a minimal sequence.

Budget: SEQUENCE_EXAMPLES campaigns (about 40 s); for a long search set BYWIRE_SEQUENCES, e.g.
`BYWIRE_SEQUENCES=2000 pytest tests/system/test_sequences.py` (about 10 minutes).
"""

from __future__ import annotations

import os

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bywire.model import ControlMode
from bywire.sim.verify.campaign import VOCABULARY, Campaign, Step

SEQUENCE_EXAMPLES = int(os.environ.get("BYWIRE_SEQUENCES", "150"))
RC, CAN = ControlMode.RC, ControlMode.CAN


def _values(action: str) -> st.SearchStrategy[tuple[str, object]]:
    values = VOCABULARY[action]
    if isinstance(values, range):
        drawn: st.SearchStrategy[object] = st.integers(values.start, values.stop - 1)
    else:
        drawn = st.sampled_from(values)
    return st.tuples(st.just(action), drawn)


OPERATOR = [
    _values(action) for action in ("arm", "flick", "handover", "rc_throttle", "can_throttle")
]
FAULTS = (
    *("switch", "rc_gear", "rc_steer", "chatter", "rc_link", "rc_failsafe", "rc_implausible"),
    *("can_gear", "can_link", "can_repeat", "remote_stop", "re_enable", "impostor", "dac"),
    *("stall", "wheel_sensor"),
)
# The actions this check was first written with; `bywire verify` draws from all of VOCABULARY
# (and its tests hold the teeth: old bugs put back, each found).
ACTIONS = st.one_of(
    *OPERATOR,
    *OPERATOR,
    *OPERATOR,  # what an operator does, three times as often as any fault
    *(_values(action) for action in FAULTS),
)
RANDOM_STEPS = st.lists(
    st.builds(
        lambda delay, action: Step(delay, action[0], action[1]),
        st.floats(0.005, 0.6),
        ACTIONS,
    ),
    min_size=1,
    max_size=30,
)


@st.composite
def driving_first(draw: st.DrawFn) -> list[Step]:
    """Most faults matter on a moving robot: a campaign starts armed and driving (by RC or by
    CAN, throttle drawn, possibly none), then goes on at random."""
    mode = draw(st.sampled_from([RC, CAN]))
    throttle = draw(st.sampled_from([0.0, 0.3, 0.6, 0.6]))
    action = "rc_throttle" if mode is RC else "can_throttle"
    prefix = [Step(0.2, "arm", mode), Step(0.15, action, throttle)]
    return prefix + draw(RANDOM_STEPS)


STEPS = driving_first()
SEQUENCES = settings(
    max_examples=SEQUENCE_EXAMPLES,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
TOTALS = {"campaigns": 0, "steps": 0, "checks": 0, "simulated_s": 0.0}


def campaign_is_safe(steps: list[Step]) -> None:
    """One campaign: every invariant holds at every pass, else the first violations."""
    result = Campaign().run(steps)
    TOTALS["campaigns"] += 1
    TOTALS["steps"] += len(steps)
    TOTALS["checks"] += result.oracle.checks
    TOTALS["simulated_s"] += result.simulated_s
    assert result.oracle.checks > 0
    assert result.oracle.violations == [], result.oracle.violations[:3]


def check_sequences() -> None:
    """The property, at this module's budget."""

    def campaign(steps: list[Step]) -> None:  # a fresh function: settings decorate it once
        campaign_is_safe(steps)

    given(STEPS)(SEQUENCES(campaign))()


@pytest.mark.long
def test_every_sequence_keeps_every_output_invariant(capsys: pytest.CaptureFixture[str]) -> None:
    TOTALS.update(campaigns=0, steps=0, checks=0, simulated_s=0.0)
    check_sequences()
    with capsys.disabled():
        print(
            f"\nsequence check: {TOTALS['campaigns']} campaigns, {TOTALS['steps']} steps, "
            f"{TOTALS['simulated_s']:.0f} s simulated, {TOTALS['checks']} passes checked"
        )
