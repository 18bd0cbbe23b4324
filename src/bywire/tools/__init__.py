"""Operator tools around the bus: the simulator's network transport and the live monitor."""
