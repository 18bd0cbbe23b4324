"""`bywire teleop`: the higher-level computer's stand-in, keyboard to CAN commands at 50 Hz."""
