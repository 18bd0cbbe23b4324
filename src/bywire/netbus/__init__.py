"""The simulated bus seen from outside, by python-can clients in other processes.

`socketcand` is the socketcand text protocol (pure), `server` a socketcand server on loopback,
`bridge` joins that server to the simulated bus (`bywire sim --serve`). (The tests' in-process
python-can view of a simulated node is `tests/netbus/sim_port_bus.py`.)
"""
