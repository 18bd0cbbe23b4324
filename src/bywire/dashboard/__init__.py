"""`bywire dashboard`: the live view of the controller itself (mode, commands, outputs, tasks)."""
