"""One pure check per output invariant of `docs/SAFETY.md`: each takes what the hardware shows
(`Outputs`), the facts the judge holds for it and its own memory, and returns its new memory and
what it found broken. None reads the world or the controller."""
