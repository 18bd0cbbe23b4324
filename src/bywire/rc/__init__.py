"""`bywire rc`: the RC calibration view (what the transmitter sends, what the controller reads,
and the calibration to paste into the robot file): observations, suggestion, sources, view."""
