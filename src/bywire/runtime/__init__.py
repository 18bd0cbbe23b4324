"""The imperative shell: readers, the periodic task loop, actuator writes and the lifecycle."""
