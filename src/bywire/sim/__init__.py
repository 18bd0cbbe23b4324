"""The simulated robot as a program: scenarios, the run, its record, summary, plot and log."""
