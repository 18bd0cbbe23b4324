"""Pure control decisions: step functions that take `now` and return outputs; no I/O, no clock."""
