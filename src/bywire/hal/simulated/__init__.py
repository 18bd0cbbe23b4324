"""The simulated robot: in-memory ports carrying real protocol bytes, on a virtual clock."""
