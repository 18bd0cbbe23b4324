"""`bywire verify`: random fault campaigns on the simulated robot, judged by the hazard oracle.

Beside the scenario runs of `bywire.sim` (which it plays its campaigns on): `actions` (what a
campaign step may do, one table), `draw` (how campaigns are drawn), `step_events` and `campaign`
(steps become a scenario, played with the oracle watching), `witness` (what each event means to the
oracle), `fault_rules` (each fault's rule for the oracle, by its name in the scenario language's
fault table `bywire.sim.faults`, which knows nothing of verify), `oracle/` (the judge: a stop
ledger, an arming tracker, one check per invariant), `engine` (the campaigns on every core, a
failure shrunk to a scenario) and `supervisor_check` (the supervisor's invariants checked on every
reachable state, and the transition table the campaigns' coverage is counted against).
"""
