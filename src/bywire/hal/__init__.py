"""Hardware abstraction: the ports (the seam) and their simulated and Linux backends."""
