"""Output levels for the checks' tests: the robot standing in STOP, and changes from it."""

from __future__ import annotations

from dataclasses import replace

from bywire.sim.verify.oracle.outputs import Outputs

CENTRE_S = 0.0015
STOPPED = Outputs(
    enable=False,
    released=False,
    throttle_volts=0.0,
    regen_volts=0.0,
    hydrobrake_duty=1.0,
    steering_pulse_s=CENTRE_S,
    speed_mps=0.0,
    forward=False,
    reverse=False,
)
"""Standing in STOP: the enable line low, the e-brake engaged, full hydraulic duty, centred."""
DRIVING = replace(
    STOPPED, enable=True, released=True, throttle_volts=1.0, hydrobrake_duty=0.0, forward=True
)
"""Driving forward: enabled, the e-brake released, throttle 1 V, no brake."""
