"""CAN log files: written by python-can's writers, read by the field's readers, decoded, plotted.

`write` streams a simulated run's bus to BLF, Vector ASC or candump `-L` (`bywire sim --log`;
`bywire monitor --record` takes its formats) and counts the frames for the run's summary; `read`
reads any python-can or candump log and decodes it with a DBC; `plot` draws it (`bywire plot`).
"""
