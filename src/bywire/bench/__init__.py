"""`bywire bench`: the figures of REQUIREMENTS §8 measured on the simulated robot in real time.

``realtime`` runs the controller on a wall-clock simulated robot through a nominal and a CAN-flood
phase; ``latency`` pairs each command with the DAC write it caused; ``virtual`` times the test
course in virtual time; ``figures`` turns the results into the table and the JSON.
"""
