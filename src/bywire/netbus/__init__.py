"""The simulated bus seen from outside: by python-can clients in other processes, or in-process.

`socketcand` is the socketcand text protocol (pure), `server` a socketcand server on loopback,
`bridge` joins that server to the simulated bus (`bywire sim --serve`), and `inprocess` makes one
node of the simulated bus a python-can bus for python-can code in the same process.
"""
