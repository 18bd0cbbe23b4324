"""Comparing output histories: the first divergence is named with both values (DAC in volts)."""

from __future__ import annotations

from bywire.hal.tape.run_record import Output
from bywire.protocol import dac6574
from bywire.replay.divergence import dac_volts, first_divergence

A = [Output(0.0, "steering_pwm", 0.0015), Output(0.0, "gpio.x", False), Output(1.0, "gpio.x", True)]


def test_identical_histories_have_no_divergence() -> None:
    assert first_divergence(A, list(A)) is None
    assert first_divergence([], []) is None


def test_a_different_value_is_named_with_both_values() -> None:
    changed = [A[0], A[1], Output(1.0, "gpio.x", False)]
    divergence = first_divergence(A, changed)
    assert divergence is not None
    assert (divergence.time_s, divergence.name) == (1.0, "gpio.x")
    assert (divergence.recorded, divergence.replayed) == (True, False)
    assert "1.000000 s: gpio.x recorded True, replayed False" in divergence.describe()


def test_a_missing_or_extra_write_is_a_divergence_at_its_instant() -> None:
    missing = first_divergence(A, A[:2])
    assert missing is not None
    assert (missing.time_s, missing.name, missing.recorded, missing.replayed) == (
        1.0,
        "gpio.x",
        True,
        False,
    )
    early = first_divergence(A, [*A[:2], Output(0.5, "gpio.x", True), A[2]])
    assert early is not None
    assert (early.time_s, early.recorded, early.replayed) == (0.5, False, True)


def test_writes_in_another_order_at_one_instant_are_a_divergence() -> None:
    swapped = first_divergence(A, [A[1], A[0], A[2]])
    assert swapped is not None
    assert (swapped.time_s, swapped.name) == (0.0, "steering_pwm")


def test_an_output_never_written_shows_as_such() -> None:
    divergence = first_divergence([Output(0.0, "dac.0", "10")], [])
    assert divergence is not None
    assert "replayed (not written)" in divergence.describe()


def test_a_dac_write_is_shown_in_volts_beside_its_i2c_frame() -> None:
    frame = dac6574.encode_write(0, 256).hex()
    other = dac6574.encode_write(0, 512).hex()
    divergence = first_divergence([Output(0.0, "dac.0", frame)], [Output(0.0, "dac.0", other)])
    assert divergence is not None
    text = divergence.describe()
    assert f"dac.0 recorded 1.250 V (I2C {frame}), replayed 2.500 V (I2C {other})" in text
    assert "recorded 0.625 V" in divergence.describe(vref_volts=2.5)  # the robot's Vref
    assert dac_volts("not hex") is None


def test_the_same_value_written_another_number_of_times_is_never_shown_as_equal_values() -> None:
    """Issue 32, defect 10: `can_tx.0x200 recorded 1104, replayed 1104`."""
    twice = [Output(1.0, "can_tx.0x200", "1104"), Output(1.0, "can_tx.0x200", "1104")]
    divergence = first_divergence(twice, twice[:1])
    assert divergence is not None
    text = divergence.describe()
    assert "recorded 1104, replayed 1104" not in text
    assert text.endswith(
        "can_tx.0x200 written 2 times (1104, 1104) at that instant in the record,"
        " 1 time (1104) on replay"
    )


def test_the_same_writes_in_another_order_say_so_with_both_orders() -> None:
    divergence = first_divergence(A, [A[1], A[0], A[2]])
    assert divergence is not None
    assert divergence.describe().endswith(
        "steering_pwm: the same writes, in another order among that instant's outputs"
        " (recorded steering_pwm, gpio.x; replayed gpio.x, steering_pwm)"
    )
