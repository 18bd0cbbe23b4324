"""`bywire sim --realtime` at a terminal: `e` presses and releases the simulated E-stop."""

from __future__ import annotations

import os
import pty
import queue
import termios

from bywire.hal.simulated.estop import SimEstopButton
from bywire.sim.estop_key import estop_key, on_key

WAIT_S = 10.0  # only a bound on a broken test: each key is seen as soon as it is typed


def test_e_toggles_the_button_and_other_keys_do_nothing() -> None:
    button = SimEstopButton()
    assert on_key(button, "x") is None
    assert not button.pressed
    assert on_key(button, "e") == "E-stop pressed"
    assert button.get() is False  # the line: low, pressed
    assert on_key(button, "E") is not None
    assert not button.pressed
    assert button.get() is True


def test_keys_typed_on_the_terminal_reach_the_button_and_the_terminal_is_restored() -> None:
    main_fd, terminal_fd = pty.openpty()
    before = termios.tcgetattr(terminal_fd)
    said: queue.Queue[str] = queue.Queue()
    button = SimEstopButton()
    with os.fdopen(terminal_fd, "r") as terminal:
        with estop_key(button, terminal, said.put):
            assert not termios.tcgetattr(terminal_fd)[3] & termios.ICANON  # a key at a time
            os.write(main_fd, b"e")
            assert said.get(timeout=WAIT_S) == "E-stop pressed"
            assert button.pressed
            os.write(main_fd, b"xe")
            assert said.get(timeout=WAIT_S).startswith("E-stop released")
            assert not button.pressed
        assert termios.tcgetattr(terminal_fd) == before
    os.close(main_fd)
