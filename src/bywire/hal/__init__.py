"""Hardware abstraction: the ports (the seam), their simulated and Linux backends, and the tape."""
