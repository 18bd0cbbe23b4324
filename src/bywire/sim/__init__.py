"""The simulated run: scenarios with their fault and condition tables, the run, its summary, plot.

Its CAN log is written by `bywire.canlog.write`, its record by `bywire.replay.recorder`.
"""
