"""Replaying a recorded run: record a simulated run, run it again on its inputs, compare.

`recorder` tapes a simulated run's controller and writes the run record; `runner` runs the
controller again on the record's inputs in virtual time (`bywire replay`); `divergence` names the
first output that differs. The ports and the record's format are the tape backend's
(`bywire.hal.tape`).
"""
