"""Hydraulic brake: the PWM duty for a brake command (thesis §3.3, Figure 13)."""

from __future__ import annotations

import math

DEFAULT_THRESHOLD_NORM = 0.5


def hydrobrake_duty(brake_norm: float, threshold_norm: float = DEFAULT_THRESHOLD_NORM) -> float:
    """Duty 0…1: zero up to the threshold, then rising linearly to 1 at full brake.

    duty = (brake − threshold) / (1 − threshold) when brake > threshold, else 0. The brake command
    is clamped to 0…1 first and a NaN counts as full brake, so that a corrupt value can only ever
    brake harder. `threshold_norm` must lie in [0, 1).
    """
    if not 0.0 <= threshold_norm < 1.0:
        raise ValueError(f"hydrobrake threshold must be in [0, 1), got {threshold_norm}")
    brake_norm = 1.0 if math.isnan(brake_norm) else min(max(brake_norm, 0.0), 1.0)
    if brake_norm <= threshold_norm:
        return 0.0
    return (brake_norm - threshold_norm) / (1.0 - threshold_norm)
