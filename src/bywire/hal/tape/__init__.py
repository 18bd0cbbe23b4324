"""The tape backend: ports that record what crosses the seam, and ports that play it back.

`taped` wraps any Hardware bundle (simulated or Linux) in ports that forward every call and note
every input and output on a tape; `run_record` is that tape's format on disk (`bywire sim
--record`); `playback` builds ports that hand a recorded run's inputs back to the controller at
their recorded instants and keep what it writes (`bywire replay`). Like `hal/simulated/` and
`hal/linux/`, both pass the conformance suite (tests/hal/test_conformance.py).
"""
