"""One telemetry feed out of the controller: snapshots in the loop, encoding and I/O elsewhere."""
